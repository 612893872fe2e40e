"""Devices: the drivers that bind a patch to the world (simulated haptic device, WAV files)."""
import os

from .files import WavInput
from .hid import HidDriver
from .simulated import SimulatedDevice, SimulatedHaptic


def _replay(name, spec):
    from .record import ReplayDevice
    return ReplayDevice(name, spec)


DRIVERS = {"simulated": SimulatedDevice, "hid": HidDriver, "replay": _replay}


class DeviceError(Exception):
    pass


def open_drivers(patch, choices=None, live_input=None):
    """A Driver for each device entry of a patch (`choices`, name → driver, overrides the file),
    and one for each block fed from a file (audio_in) — or, with `live_input` (play gives it), a
    live input driver `live_input(block)` for an audio_in block with no file. A device entry's
    `file` (a replay take) is relative to the patch."""
    choices = dict(choices or {})
    unknown = set(choices) - set(patch.devices)
    if unknown:
        raise DeviceError(f"--device: the patch declares no device named {', '.join(sorted(unknown))}")
    drivers = {}
    base = os.path.dirname(os.path.abspath(patch.file))
    for name, spec in patch.devices.items():
        kind = choices.get(name) or spec.get("driver", "simulated")
        factory = DRIVERS.get(kind)
        if factory is None:
            raise DeviceError(f"device {name!r}: driver {kind!r} is not available in this build "
                              f"(available: {', '.join(sorted(DRIVERS))})")
        if isinstance(spec.get("file"), str):
            spec = {**spec, "file": os.path.join(base, spec["file"])}
        drivers[name] = factory(name, spec)
    for inst in patch.blocks.values():
        if inst.cls.type_name == "audio_in":
            if not inst.values["file"] and live_input is not None:
                drivers[inst.name] = live_input(inst)
                continue
            if not inst.values["file"]:
                raise DeviceError(f"block {inst.name!r} (audio_in): no file given, and live input needs `play`")
            path = os.path.join(base, inst.values["file"])
            try:
                drivers[inst.name] = WavInput(path, inst.values["channel"], inst.values["loop"])
            except (OSError, ValueError) as exc:
                raise DeviceError(f"block {inst.name!r} (audio_in): cannot read {inst.values['file']!r}: {exc}") from None
    return drivers


__all__ = ["DRIVERS", "DeviceError", "SimulatedDevice", "SimulatedHaptic", "WavInput", "open_drivers"]
