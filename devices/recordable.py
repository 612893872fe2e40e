"""What a take asks of a driver besides the engine's Driver protocol (hapticgraph.devices.record)."""


class Recordable:
    """A driver whose device model computes its inputs inside the kernel (the simulated hand
    follows its script there): it fills its columns only while a take is recorded (`recording`,
    set by the recorder), and a take names the model that replays those columns (`take_type`)
    with the values of it the take keeps (`take_values()`)."""

    take_type = None
    recording = False

    def take_values(self):
        return {}


__all__ = ["Recordable"]
