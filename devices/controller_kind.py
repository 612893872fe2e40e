"""Controllers: devices that play blocks rather than being one (MIDI, OSC). A ControllerKind's
device binds to no block of its own; each block naming it (`controls`: their types) is fed by a
tap of its driver, a Hub (hapticgraph.devices.events), through the ControllerInputKind. The
controllers' `map:` section (hapticgraph.devices.mapping) turns into such blocks."""
from ..blocks.controllers import MidiCC, MidiNote, OscIn
from .driver_kind import DriverKind, InputKind
from .errors import DeviceError
from .mapping import check_controls, expand, map_schema


class ControllerKind(DriverKind):
    """A device that plays blocks of the types `controls` names."""

    controls = ()

    def settings(self):
        return {}

    def sections(self):
        return {"map": map_schema()}

    def prepare(self, doc, registry, problems):
        """Controller blocks name a device that can play them; `map:` becomes blocks."""
        check_controls(doc, registry, problems)
        return expand(doc, registry, problems)

    def axes(self, spec):
        return []


class ControllerInputKind(InputKind):
    """The driver of a block played by a controller device (midi_note, midi_cc, osc_in): a tap
    of the hub opened for the device the block names."""

    name = "controller input"
    feeds = (MidiNote, MidiCC, OscIn)

    def open(self, inst, base, live_input=None, drivers=None):
        from .events import Hub        # the hubs' module (the engine): when a block is opened
        hub = (drivers or {}).get(inst.values["device"])
        if not isinstance(hub, Hub):
            raise DeviceError(f"block {inst.name!r} ({inst.cls.type_name}): device {inst.values['device']!r} "
                              f"is not open as a controller")
        return hub.tap(inst)


__all__ = ["ControllerInputKind", "ControllerKind"]
