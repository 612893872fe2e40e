"""The layout of a HID device's reports and their decoding into SI values (pure data and
arithmetic; hapticgraph.devices.hid_profiles reads these from a profile file, the reader thread
of hapticgraph.devices.hid decodes each report with a Decoder).

The keys of a field and of a report are described with the profile format, in
hapticgraph.devices.hid_profiles.

Velocity estimate (profile `velocity: estimate`)
    v_raw = (x_k − x_{k−1}) / interval, the backward difference over the report interval, then
    v_k = v_{k−1} + a·(v_raw − v_{k−1}) with a = 1 − exp(−2π·velocity_cutoff·interval). Devices
    that report only on change (mice, gamepads) send nothing when still: after two intervals
    without a report the estimator takes a step with no motion (v_raw = 0), and again every
    two intervals, so v decays to 0 (exactly 0 below 1 nm/s). The first report gives v_raw = 0.
"""
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .velocity import VelocityEstimate


@dataclass(frozen=True)
class Field:
    """Where one value sits in a report and how its counts become SI units."""

    name: str
    byte: int
    bit: int = 0
    size: int = 8
    signed: bool = False
    endian: str = "little"
    scale: float = 1.0
    offset: float = 0.0
    relative: bool = False
    unit: str = ""
    line: int = 0

    @property
    def first_bit(self):
        return 8 * self.byte + self.bit

    @property
    def end_bit(self):
        return self.first_bit + self.size

    @property
    def span(self):
        """(first byte, bytes covered)."""
        return self.byte, (self.bit + self.size + 7) // 8

    def limits(self):
        """The smallest and largest count the field holds."""
        if self.signed:
            return -(1 << (self.size - 1)), (1 << (self.size - 1)) - 1
        return 0, (1 << self.size) - 1

    def counts(self, data):
        """The raw (integer) counts of this field in report data (the bytes after the id)."""
        start, n = self.span
        chunk = data[start:start + n]
        if self.endian == "big":
            raw = int.from_bytes(chunk, "big")
        else:
            raw = (int.from_bytes(chunk, "little") >> self.bit) & ((1 << self.size) - 1)
        if self.signed and raw >> (self.size - 1):
            raw -= 1 << self.size
        return raw

    def value(self, data):
        """SI value (for a relative axis: the change this report carries)."""
        return (self.counts(data) - self.offset) * self.scale

    def put(self, buf, at, counts):
        """Write integer counts into buf (a bytearray) with the field starting at byte `at`."""
        lo, hi = self.limits()
        counts = min(max(int(counts), lo), hi) & ((1 << self.size) - 1)
        start, n = self.span
        start += at
        if self.endian == "big":
            buf[start:start + n] = counts.to_bytes(n, "big")
            return
        mask = ((1 << self.size) - 1) << self.bit
        word = int.from_bytes(buf[start:start + n], "little")
        word = (word & ~mask) | (counts << self.bit)
        buf[start:start + n] = word.to_bytes(n, "little")


@dataclass(frozen=True)
class InputReport:
    report_id: int
    length: int
    interval: float
    axes: tuple
    buttons: tuple
    timeout: float = None
    position: str = None
    velocity: str = "estimate"
    velocity_cutoff: float = 50.0

    @property
    def read_size(self):
        """Bytes hidapi returns for one report: the id byte (numbered reports) and the data."""
        return self.length + (1 if self.report_id else 0)

    def data(self, report):
        """The report's data (after the id byte), or None if it is another report or too short."""
        if self.report_id:
            if len(report) < 1 or report[0] != self.report_id:
                return None
            report = report[1:]
        if len(report) < self.length:
            return None
        return report

    def axis(self, name):
        for f in self.axes:
            if f.name == name:
                return f
        return None


@dataclass(frozen=True)
class OutputReport:
    report_id: int
    length: int
    force: Field

    def buffer(self):
        """A zeroed report as hidapi writes it: the id byte (0 for unnumbered reports), then the data."""
        buf = bytearray(1 + self.length)
        buf[0] = self.report_id
        return buf

    def encode(self, force, buf=None):
        """The report carrying `force` [N] (already clamped by the caller); rounds to counts."""
        buf = self.buffer() if buf is None else buf
        self.force.put(buf, 1, round(force * self.force.scale))
        return buf

    def decode(self, report):
        """The force [N] a written report carries (for tests and replays)."""
        return self.force.counts(bytes(report[1:])) / self.force.scale


@dataclass(frozen=True)
class Profile:
    name: str
    file: str
    vendor_id: int
    product_id: int
    input: InputReport
    output: OutputReport = None
    max_force: float = 0.0
    description: str = ""

    @property
    def ports(self):
        """The haptic block's extra output ports: every axis, then every button, in file order."""
        return tuple(f.name for f in self.input.axes) + tuple(f.name for f in self.input.buttons)

    def decoder(self):
        """A Decoder of this profile's reports (the Layout protocol)."""
        return Decoder(self)


class Layout(Protocol):
    """What the HID driver reads of a device's layout: a Profile, or a device described by its
    report descriptor (hapticgraph.devices.hid_layout.DescribedDevice)."""

    name: str
    vendor_id: int
    product_id: int
    input: object            # .interval [s], .timeout [s] or None, .read_size [bytes]
    output: object           # an OutputReport, or None: nothing is sent
    max_force: float

    @property
    def ports(self): ...

    def decoder(self): ...


# -- decoding ----------------------------------------------------------------------------------

class Decoder:
    """Turns one report into a row [x, v, axis…, button…] (SI), keeping what spans reports:
    the running sums of relative axes and the velocity estimate."""

    def __init__(self, profile):
        self.profile = profile
        inp = profile.input
        self.axes, self.buttons = inp.axes, inp.buttons
        names = [f.name for f in inp.axes]
        self.pos = names.index(inp.position) if inp.position else None
        self.vel = names.index(inp.velocity) if inp.velocity not in (None, "estimate") else None
        self.estimate = self.pos is not None and self.vel is None
        self.velocity = VelocityEstimate(inp.velocity_cutoff or 0.0, inp.interval)
        self.interval = inp.interval
        self.width = 2 + len(inp.axes) + len(inp.buttons)
        self.reset()

    def reset(self):
        self.values = np.zeros(len(self.axes))
        self.velocity.reset()
        self.row = np.zeros(self.width)

    def decode(self, report, out):
        """Decode a report (with its id byte if numbered) into `out`; False if it is not ours."""
        data = self.profile.input.data(report)
        if data is None:
            return False
        values = self.values
        for k, f in enumerate(self.axes):
            value = f.value(data)
            values[k] = values[k] + value if f.relative else value
        x = values[self.pos] if self.pos is not None else 0.0
        velocity = self.velocity
        if self.vel is not None:
            velocity.v, velocity.x_prev = values[self.vel], x
        elif self.estimate:
            velocity.step(x)
        else:
            velocity.x_prev = x
        row = self.row
        row[0], row[1] = x, velocity.v
        row[2:2 + len(values)] = values
        base = 2 + len(values)
        for k, f in enumerate(self.buttons):
            row[base + k] = f.counts(data)
        out[:] = row
        return True

    def still(self, out):
        """A step with no motion (for report-on-change devices that went quiet); False if the
        velocity is not estimated (nothing changes then)."""
        if not self.estimate or not self.velocity.decay():
            return False
        self.row[1] = self.velocity.v
        out[:] = self.row
        return True


__all__ = ["Decoder", "Field", "InputReport", "Layout", "OutputReport", "Profile"]
