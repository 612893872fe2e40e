"""A HID device without a profile: its layout read from its report descriptor
(hapticgraph.devices.hid_descriptor), and the decoding of its reports into a row of values.

`DescribedDevice` offers what the HID driver (hapticgraph.devices.hid) reads of a layout, as a
Profile does (hapticgraph.devices.hid_reports.Layout): `name`, `vendor_id`, `product_id`,
`ports`, `input` (interval, timeout, read_size), `output`, `max_force` and `decoder()`.

The haptic block's `x` is the device's X axis (−1 … 1; 0 when it has none) and `v` its estimated
velocity (per second), as for the gamepad profile; every other input is an output port of the
block, named by the descriptor (y, rz, slider, hat_x, hat_y, hat, button1, ...). A device
without a force output (the HID PID force reports are listed by `hapticgraph hid describe`, not
yet driven) is sent nothing: its max_force is 0 and the force the patch puts out is dropped.

Values are held between reports; a relative field (a mouse's or a 3-D mouse's motion) falls back
to 0 after two report intervals without a report, as the velocity estimate decays (hid_reports).
"""
import math
from dataclasses import dataclass

import numpy as np

from .velocity import VelocityEstimate

HAT_DIRECTIONS = ((0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1))   # up, clockwise
DEFAULT_INTERVAL = 0.008       # s: USB full-speed HID devices are polled at 125 Hz unless they say
VELOCITY_CUTOFF = 20.0         # Hz: smoothing of the x velocity estimate (the gamepad profile's)


@dataclass(frozen=True)
class Timing:
    """What the driver reads of a layout's input: the report interval [s], the silence that means
    the device is lost (None: report-on-change devices are never lost for being still) and the
    bytes one read returns."""

    interval: float
    timeout: float = None
    read_size: int = 64


class DescribedDevice:
    """A device as its report descriptor describes it (see the module's doc).

    `descriptor`: a Descriptor (hapticgraph.devices.hid_descriptor.parse); `collection`: keep only
    the inputs of that top-level collection (its index); `interval`: the report interval [s] if
    known (a recording's)."""

    output = None
    max_force = 0.0

    def __init__(self, descriptor, name="", vendor_id=0, product_id=0, interval=DEFAULT_INTERVAL,
                 collection=None, source=""):
        desc = self.descriptor = descriptor
        self.name, self.vendor_id, self.product_id = name or "hid device", vendor_id, product_id
        self.source = source
        self.inputs = tuple(i for i in desc.inputs if collection is None or i.collection == collection)
        self.position = next((i for i in self.inputs if i.name == "x" and i.kind == "axis"), None)
        self.ports = tuple(p for i in self.inputs if i is not self.position for p in i.ports)
        self.input = Timing(float(interval), None, desc.read_size())
        self.file = source

    @property
    def force_feedback(self):
        return self.descriptor.force_feedback

    def decoder(self):
        return DescriptorDecoder(self)


def axis_value(i, raw):
    """An input field's raw count as players expect it (centred axes −1…1, pedals 0…1, units when
    the descriptor gives them)."""
    lo, hi = i.logical_min, i.logical_max
    if hi == lo:
        return float(raw)
    if not i.relative:
        raw = min(max(raw, min(lo, hi)), max(lo, hi))
    if i.scaling == "physical":
        return (i.physical_min + (raw - lo) * (i.physical_max - i.physical_min) / (hi - lo)) * i.factor
    if i.scaling == "positive":
        return (raw - lo) / (hi - lo)
    if i.signed:
        return raw / hi if raw >= 0 and hi > 0 else (-raw / lo if lo < 0 else 0.0)
    return 2.0 * (raw - lo) / (hi - lo) - 1.0


class DescriptorDecoder:
    """Turns one report into the row [x, v, port…] (see hapticgraph.devices.hid_reports.Decoder
    for the velocity estimate, which this one shares)."""

    def __init__(self, layout):
        self.layout = layout
        self.numbered = layout.descriptor.numbered
        self.sizes = layout.descriptor.report_sizes
        self.interval = layout.input.interval
        self.velocity = VelocityEstimate(VELOCITY_CUTOFF, self.interval)
        self.width = 2 + len(layout.ports)
        column = {p: 2 + k for k, p in enumerate(layout.ports)}
        self.by_report = {}
        for i in layout.inputs:
            cols = (0,) if i is layout.position else tuple(column[p] for p in i.ports)
            self.by_report.setdefault(i.report_id, []).append((i, cols))
        self.relative = [cols[0] for items in self.by_report.values() for i, cols in items if i.relative]
        self.hats = [cols[2] for items in self.by_report.values() for i, cols in items if i.kind == "hat"]
        self.reset()

    def reset(self):
        self.row = np.zeros(self.width)
        self.row[self.hats] = math.nan          # a hat is centred until it says otherwise
        self.velocity.reset()

    def decode(self, report, out):
        """Decode a report (with its id byte if numbered) into `out`; False if it is not one of ours."""
        report = bytes(report)
        if self.numbered:
            if not report:
                return False
            rid, data = report[0], report[1:]
        else:
            rid, data = 0, report
        items = self.by_report.get(rid)
        if items is None or len(data) < self.sizes.get(rid, 0):
            return False
        word = int.from_bytes(data, "little")
        row = self.row
        arrays = {}
        for i, cols in items:
            if i.array_value is not None:
                key = (i.bit_offset, i.bit_size, i.array_count)
                if key not in arrays:
                    mask = (1 << i.bit_size) - 1
                    arrays[key] = {(word >> (i.bit_offset + k * i.bit_size)) & mask for k in range(i.array_count)}
                row[cols[0]] = 1.0 if i.array_value in arrays[key] else 0.0
                continue
            raw = (word >> i.bit_offset) & ((1 << i.bit_size) - 1)
            if i.signed and i.bit_size > 1 and raw >> (i.bit_size - 1):
                raw -= 1 << i.bit_size
            if i.kind == "button":
                row[cols[0]] = 0.0 if raw == i.logical_min else 1.0
            elif i.kind == "hat":
                self._hat(i, raw, cols)
            else:
                row[cols[0]] = axis_value(i, raw)
        row[1] = self.velocity.step(row[0])
        out[:] = row
        return True

    def _hat(self, i, raw, cols):
        lo, hi = i.logical_min, i.logical_max
        if not lo <= raw <= hi:                  # the null state: centred
            self.row[cols[0]] = self.row[cols[1]] = 0.0
            self.row[cols[2]] = math.nan
            return
        n = hi - lo + 1
        dx, dy = HAT_DIRECTIONS[((raw - lo) * 8 // n) % 8]
        self.row[cols[0]], self.row[cols[1]] = dx, dy
        self.row[cols[2]] = (raw - lo) * 360.0 / n

    def still(self, out):
        """A step with no report: relative fields fall back to 0 and the velocity decays; False
        if nothing changed."""
        row = self.row
        moved = bool(self.relative) and bool(np.any(row[self.relative]))
        row[self.relative] = 0.0
        moved = self.velocity.decay() or moved
        if not moved:
            return False
        if self.layout.position is not None and self.layout.position.relative:
            self.velocity.x_prev = row[0]
        row[1] = self.velocity.v
        out[:] = row
        return True


__all__ = ["DEFAULT_INTERVAL", "DescribedDevice", "DescriptorDecoder", "Timing", "axis_value"]
