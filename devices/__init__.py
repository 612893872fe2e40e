"""Devices: the drivers that bind a patch to the world (simulated haptic device, HID, serial,
MIDI, OSC, replay, WAV files). The drivers are one table, read from the entry-point group
`hapticgraph.drivers` (.table), each kind beside its driver (.simulated_kind beside .simulated,
...); .opening opens a patch's. The drivers' code (numpy, soundfile, threads) is imported when
first used (PEP 562), so the loader can ask the kinds about a patch without it."""
import importlib

from .errors import DeviceError
from .opening import Choice, check_choices, driver_settings, open_drivers, parse_choice
from .table import driver_kinds, input_kind, kinds_of

# public name -> (module, attribute): imported when first used
_LAZY = {"HidDriver": (".hid", "HidDriver"), "SimulatedDevice": (".simulated", "SimulatedDevice"),
         "SimulatedHaptic": (".simulated", "SimulatedHaptic"), "WavInput": (".files", "WavInput")}


def __getattr__(name):
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module, __name__), attr)
    globals()[name] = value
    return value


__all__ = ["Choice", "DeviceError", "check_choices", "driver_kinds", "driver_settings", "input_kind", "kinds_of",
           "open_drivers", "parse_choice", "SimulatedDevice", "SimulatedHaptic", "WavInput"]
