"""`driver: midi`: a live MIDI port or a Standard MIDI File (its driver: hapticgraph.devices.midi)."""
import os

from .controller_kind import ControllerKind


class MidiKind(ControllerKind):
    """MIDI plays midi_note and midi_cc blocks."""

    name = "midi"
    controls = ("midi_note", "midi_cc")

    def settings(self):
        return {"port": {"type": "string", "minLength": 1,
                         "description": "play live from the first MIDI input port whose name contains this"},
                "file": {"type": "string", "minLength": 1,
                         "description": "a Standard MIDI File beside the patch, rendered headless"},
                "api": {"enum": ["auto", "jack", "alsa"], "default": "auto",
                        "description": "the MIDI system a live port is looked for in"}}

    def check(self, name, spec, base, problems):
        if "port" in spec and "file" in spec:
            problems.add(spec.lines.get("file", spec.line), f"device {name!r}: give a MIDI `port` or a `file`, not both")
        ref = spec.get("file")
        if isinstance(ref, str) and ref and not os.path.isfile(os.path.join(base, ref)):
            problems.add(spec.lines.get("file", spec.line), f"device {name!r}: no MIDI file {ref!r} beside the patch")

    def open(self, name, spec, patch):
        from .midi import MidiHub        # the driver's module (mido, the engine): when opened
        return MidiHub(name, spec)


__all__ = ["MidiKind"]
