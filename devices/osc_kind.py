"""`driver: osc`: OSC messages over UDP (its driver: hapticgraph.devices.osc)."""
from .controller_kind import ControllerKind


class OscKind(ControllerKind):
    """OSC plays osc_in blocks."""

    name = "osc"
    controls = ("osc_in",)

    def settings(self):
        return {"port": {"type": "integer", "minimum": 0, "maximum": 65535, "default": 9000,
                         "description": "the UDP port to listen on (0: any free port)"},
                "host": {"type": "string", "minLength": 1, "default": "127.0.0.1",
                         "description": "the address to listen on (0.0.0.0: every network interface)"}}

    def open(self, name, spec, patch):
        from .osc import OscHub          # the driver's module (python-osc, the engine): when opened
        return OscHub(name, spec)


__all__ = ["OscKind"]
