"""The driver kind of `driver: sine`: the settings of its device entry, what the loader checks,
and how its driver opens. Imported whenever a patch is loaded, so it only imports hapticgraph's
light kind base; the driver's module (numpy, the engine) is imported when a device opens."""
import math

from hapticgraph.devices.driver_kind import NUMBER, DriverKind


class SineKind(DriverKind):
    """A hand that moves the device sinusoidally."""

    name = "sine"

    def settings(self):
        return {**super().settings(),
                "frequency": {**NUMBER, "exclusiveMinimum": 0, "maximum": 20000, "default": 2.0,
                              "description": "how often the hand goes back and forth [Hz]"},
                "amplitude": {**NUMBER, "minimum": 0, "maximum": 1, "default": 0.005,
                              "description": "how far the hand goes each way [m]"}}

    def check(self, name, spec, base, problems):
        frequency, amplitude = spec.get("frequency", 2.0), spec.get("amplitude", 0.005)
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (frequency, amplitude)):
            return                       # the schema reports it
        speed = 2.0 * math.pi * frequency * amplitude
        if speed > 10.0:
            problems.add(spec.lines.get("frequency", spec.line),
                         f"device {name!r}: the hand would move at up to {speed:.3g} m/s; a hand does not go over 10 m/s")

    def open(self, name, spec, patch):
        from .driver import SineHand
        return SineHand(name, spec.get("frequency", 2.0), spec.get("amplitude", 0.005), spec.get("max_force", 4.0))
