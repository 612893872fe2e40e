"""A haptic device's ports in a patch. The engine binds the block to the patch's device entry:
with a measured device the sensor values come in as External columns and the force input goes
out to the driver (which clamps it to the device's max_force); a driver may substitute a
subclass that models the device itself (see hapticgraph.devices.simulated)."""
import math

from .vocabulary import Block, External, In, Out, Param, helper


@helper
def clamp_force(force, limit):
    """The force the hand may receive: NaN or infinite becomes 0, the rest is clipped to ±limit."""
    if not math.isfinite(force):
        return 0.0
    return min(max(force, -limit), limit)


class Haptic(Block, name="haptic"):
    """x[n], v[n] from the device's sensor; force[n] goes to its actuator, clipped to ±max_force."""

    drawing = {"dot": "hexagon", "mermaid": ("{{", "}}")}
    force = In(doc="force the patch applies to the device [N]; read after the sensor, so no feedthrough",
               sends=True)
    x = Out(doc="device position [m]")
    v = Out(doc="device velocity [m/s]")
    device = Param("", refers="devices", doc="the name of an entry under devices:")
    axes = Param([], internal=True, schema={"type": "array", "items": {"type": "string"}},
                 doc="the device's other axes and buttons (set from its entry), each an output port")
    sensor_x = External()
    sensor_v = External()

    @classmethod
    def ports(cls, values):
        extra = []
        for name in values.get("axes", ()):
            port = Out(doc="a device axis or button, straight from its driver")
            port.attr, port.external = name, True
            extra.append(port)
        return cls.inputs, cls.outputs + tuple(extra)

    @staticmethod
    def output(sensor_x, sensor_v):
        return sensor_x, sensor_v
