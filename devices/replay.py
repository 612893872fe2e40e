"""Replaying a take (hapticgraph.devices.take): `hapticgraph run PATCH --replay TAKE` (every
device and audio input from the take) or a device entry `{driver: replay, file: TAKE.hgrec}` (one
device). The take is checked against the patch before anything runs."""
import math
import os

import numpy as np

from ..graph.engine import Driver
from .take import MODELS, Take, TakeError


class ReplayDriver(Driver):
    """Feeds one device (or audio input) of a patch from a take, sample for sample; past the
    end a device holds its last values and an audio input is silent. It offers the block type
    and internal values the device had when recorded, so the kernel is the one that played."""

    def __init__(self, name, take, info):
        self.name, self.take = name, take
        self.columns = tuple(info["columns"])
        self.block_type = MODELS.get(take.model_of(name, info))
        self.values = dict(info.get("block_values") or {})
        # the bound the device clamped to: its model's value, or the take's (serial, HID devices)
        self.max_force = float(self.values.get("max_force", info.get("max_force", math.inf)))
        off = int(info["offset"])
        self.signal = np.ascontiguousarray(take.inputs[:, off:off + len(self.columns)])
        self.hold = not info.get("input", False)
        self.sent = []

    def block_values(self):
        return dict(self.values)

    def start(self, rate):
        if float(rate) != self.take.rate:
            raise TakeError(f"{os.path.basename(self.take.path)} was recorded at {self.take.rate:g} Hz, "
                            f"the patch runs at {float(rate):g} Hz")
        self.sent = []

    def fill(self, t0, ext):
        n, total = ext.shape[0], self.signal.shape[0]
        k = max(0, min(n, total - t0))
        if k:
            ext[:k] = self.signal[t0:t0 + k]
        if k < n:
            ext[k:] = self.signal[-1] if (self.hold and total) else 0.0

    def send(self, t0, force):
        # nothing reaches a hand here, but what is kept is what a device would have received:
        # a value not finite as 0, each clamped to max_force (not np.nan_to_num, whose Python-level
        # work cost a servo loop of 1-sample blocks 10 µs a call, more than the kernel)
        force = np.array(force, dtype=np.float64)
        bad = ~np.isfinite(force)
        if bad.any():
            force[bad] = 0.0
        self.sent.append(np.clip(force, -self.max_force, self.max_force, out=force))

    def force_sent(self):
        return np.concatenate(self.sent) if self.sent else np.zeros(0)


def ReplayDevice(name, spec, patch):
    """`driver: replay` in a device entry: `{driver: replay, file: TAKE.hgrec}` (the file is
    relative to the patch); feeds that device from the take, checked against the patch's device."""
    path = spec.get("file")
    if not path:
        raise TakeError(f"device {name!r}: driver replay needs a take: give the entry `file: TAKE.hgrec`, "
                        "or replay a whole take with `hapticgraph run PATCH --replay TAKE.hgrec`")
    take = Take(path)
    take.check_device(patch, name)
    return take_driver(take, name)


def take_driver(take, name):
    """The ReplayDriver of device (or input) `name` of `take`; TakeError if it has none."""
    return ReplayDriver(name, take, take.driver_info(name))


def replay_drivers(patch, path):
    """Drivers for every device and audio input of `patch` from the take at `path` (checked)."""
    take = Take(path)
    take.check(patch)
    return take, {name: take_driver(take, name) for name in take.header["drivers"]} | {
        name: _Idle(name) for name in patch.devices if name not in take.header["drivers"]}


class _Idle(Driver):
    """A declared device no block used when the take was made (it supplied no columns)."""

    def __init__(self, name):
        self.name = name


__all__ = ["ReplayDevice", "ReplayDriver", "replay_drivers", "take_driver"]
