"""Devices: the drivers that bind a patch to the world (simulated haptic device, WAV files)."""
import os

from .files import WavInput
from .simulated import SimulatedDevice, SimulatedHaptic

DRIVERS = {"simulated": SimulatedDevice}


class DeviceError(Exception):
    pass


def open_drivers(patch, choices=None):
    """A Driver for each device entry of a patch (`choices`, name → driver, overrides the file),
    and one for each block fed from a file (audio_in)."""
    choices = dict(choices or {})
    unknown = set(choices) - set(patch.devices)
    if unknown:
        raise DeviceError(f"--device: the patch declares no device named {', '.join(sorted(unknown))}")
    drivers = {}
    for name, spec in patch.devices.items():
        kind = choices.get(name) or spec.get("driver", "simulated")
        factory = DRIVERS.get(kind)
        if factory is None:
            raise DeviceError(f"device {name!r}: driver {kind!r} is not available in this build "
                              f"(available: {', '.join(sorted(DRIVERS))})")
        drivers[name] = factory(name, spec)
    base = os.path.dirname(os.path.abspath(patch.file))
    for inst in patch.blocks.values():
        if inst.cls.type_name == "audio_in":
            if not inst.values["file"]:
                raise DeviceError(f"block {inst.name!r} (audio_in): no file given, and live input needs `play`")
            path = os.path.join(base, inst.values["file"])
            try:
                drivers[inst.name] = WavInput(path, inst.values["channel"], inst.values["loop"])
            except (OSError, ValueError) as exc:
                raise DeviceError(f"block {inst.name!r} (audio_in): cannot read {inst.values['file']!r}: {exc}") from None
    return drivers


__all__ = ["DRIVERS", "DeviceError", "SimulatedDevice", "SimulatedHaptic", "WavInput", "open_drivers"]
