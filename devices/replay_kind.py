"""`driver: replay`: a device fed from a take (its driver: hapticgraph.devices.replay)."""
from .driver_kind import DriverKind


class ReplayKind(DriverKind):
    """A device replayed from a take; other keys of the entry (written for the driver it replays)
    are kept."""

    name = "replay"
    required = ("file",)
    closed = False

    def settings(self):
        return {**super().settings(), "file": {"type": "string"}}

    def open(self, name, spec, patch):
        from .replay import ReplayDevice       # the driver's module (the engine, the take reader)
        return ReplayDevice(name, spec, patch)


__all__ = ["ReplayKind"]
