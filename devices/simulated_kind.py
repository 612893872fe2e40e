"""`driver: simulated`, the default: a hand on a model of the device (its driver:
hapticgraph.devices.simulated)."""
from ..graph.entries import device_axes
from ..graph.source import LList
from .driver_kind import NUMBER, SCRIPT_RESERVED, DriverKind
from .limits import SIMULATED_MAX_FORCE, check_limit
from .table import kinds_of


class SimulatedKind(DriverKind):
    """The simulated haptic device: a moving mass held by a hand that follows a script."""

    name = "simulated"
    default = True
    model_columns = ("hand_x", "hand_v")

    @property
    def model(self):
        from .simulated import SimulatedHaptic       # the driver's module (the engine): when asked
        return SimulatedHaptic

    def settings(self):
        keyframe = {"type": "object", "required": ["t"],
                    "propertyNames": {"pattern": r"^[A-Za-z_][A-Za-z0-9_]*(?![\s\S])",
                                      "not": {"enum": [k for k in SCRIPT_RESERVED if k not in ("t", "x")]}},
                    "additionalProperties": {**NUMBER,
                                             "description": "another axis or button of the device, an output port"},
                    "properties": {"t": {**NUMBER, "minimum": 0, "description": "time [s]"},
                                   "x": {**NUMBER, "minimum": -1, "maximum": 1, "description": "hand position [m]"}}}
        return {**super().settings(),
                "mass": {**NUMBER, "exclusiveMinimum": 0, "maximum": 100, "default": 0.05,
                         "description": "moving mass of the device [kg]"},
                "hand_stiffness": {**NUMBER, "minimum": 0, "maximum": 1e6, "default": 400.0,
                                   "description": "stiffness of the hand's grip [N/m]"},
                "hand_damping": {**NUMBER, "minimum": 0, "maximum": 1e4, "default": 4.0,
                                 "description": "damping of the hand's grip [N·s/m]"},
                "script": {"type": "array", "items": keyframe, "minItems": 1,
                           "description": "keyframes the hand follows, linear between them"},
                "hold": {"type": "boolean", "default": True,
                         "description": "keep the last keyframe (true) or repeat the script (false)"}}

    def check(self, name, spec, base, problems):
        check_limit(spec, name, SIMULATED_MAX_FORCE, "the simulated device's bound", problems)
        script = spec.get("script")
        if not isinstance(script, LList):
            return
        last = None
        for key, line in zip(script, script.lines):
            t = key.get("t") if isinstance(key, dict) else None
            if isinstance(t, (int, float)) and not isinstance(t, bool):
                if last is not None and t < last:
                    problems.add(line, f"device {name!r}: script keyframe at t = {t} s goes back in time "
                                       f"(the previous one is at t = {last} s)")
                last = t

    def open(self, name, spec, patch):
        from .simulated import SimulatedDevice
        # the axes the patch sees: those of the file's entry, whichever driver it was written for
        return SimulatedDevice(name, spec, axes=device_axes(patch.devices, name, kinds_of(patch)))


__all__ = ["SimulatedKind"]
