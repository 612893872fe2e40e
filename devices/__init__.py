"""Devices: the drivers that bind a patch to the world (simulated haptic device, WAV files)."""
from .simulated import SimulatedDevice, SimulatedHaptic

DRIVERS = {"simulated": SimulatedDevice}


class DeviceError(Exception):
    pass


def open_drivers(patch, choices=None):
    """A Driver for each device entry of a patch; `choices` (name → driver) overrides the file."""
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
    return drivers


__all__ = ["DRIVERS", "DeviceError", "SimulatedDevice", "SimulatedHaptic", "open_drivers"]
