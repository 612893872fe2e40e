"""Driver kinds of the controllers: serial haptic devices, MIDI and OSC (see devices/kinds.py)."""
import os

from ..blocks.controllers import MidiCC, MidiNote, OscIn
from ..graph.errors import PatchError
from .kinds import DriverKind, _check_limit, same  # noqa: F401 - kinds imports this module after defining them


class SerialKind(DriverKind):
    """`driver: serial`: a haptic device on a serial line, described by a wire-protocol profile
    (hapticgraph.devices.serial_port, .serial_profiles)."""

    name = "serial"
    required = ("profile", "port")

    def settings(self):
        return {**super().settings(),
                "profile": {"type": "string", "minLength": 1,
                            "description": "a shipped serial profile's name (fader_1dof, pantograph_2dof) "
                                           "or a profile .yaml file beside the patch"},
                "port": {"type": "string", "minLength": 1, "description": "the serial port, e.g. /dev/ttyACM0"},
                "baudrate": {"type": "integer", "minimum": 300, "maximum": 50_000_000,
                             "description": "bits per second, if not the profile's"}}

    def check(self, name, spec, base, problems):
        from .serial_profiles import find_profile, load_profile, shipped_profiles
        ref = spec.get("profile")
        if not isinstance(ref, str):
            return
        path = find_profile(ref, base)
        if path is None:
            problems.add(spec.lines.get("profile", spec.line), f"device {name!r}: no serial profile {ref!r} "
                         f"(shipped: {', '.join(shipped_profiles())}; or a .yaml file beside the patch)")
            return
        try:
            spec.serial_profile = load_profile(path)
        except PatchError as exc:
            problems.add(spec.lines.get("profile", spec.line), f"device {name!r}: serial profile {ref!r} has "
                         f"{len(exc.problems)} problem(s), listed at its own file and lines")
            problems.problems.extend(exc.problems)
            return
        _check_limit(spec, name, spec.serial_profile.max_force,
                     f"the bound its profile {spec.serial_profile.name!r} states", problems)

    def axes(self, spec):
        profile = getattr(spec, "serial_profile", None)
        return list(profile.ports) if profile is not None else []

    def override(self, spec, settings, drop=()):
        entry = super().override(spec, settings, drop)
        if "profile" not in settings and hasattr(spec, "serial_profile"):
            entry.serial_profile = spec.serial_profile
        return entry

    def open(self, name, spec, patch):
        from . import DeviceError
        from .serial_port import SerialDriver
        profile = getattr(spec, "serial_profile", None)
        if profile is None:
            from .serial_profiles import find_profile, load_profile
            path = find_profile(str(spec.get("profile", "")), os.path.dirname(os.path.abspath(patch.file)))
            if path is None:
                raise DeviceError(f"device {name!r}: no serial profile {spec.get('profile')!r}")
            profile = load_profile(path)
        return SerialDriver(name, spec, profile)


class ControllerKind(DriverKind):
    """A device that plays blocks rather than being one (MIDI, OSC): it binds to no block of its
    own; each block naming it (`controls`: their types) is fed by a tap of its driver."""

    controls = ()

    def settings(self):
        return {}

    def sections(self):
        from .mapping import map_schema
        return {"map": map_schema()}

    def prepare(self, doc, registry, problems):
        """Controller blocks name a device that can play them; `map:` becomes blocks."""
        from .mapping import check_controls, expand
        check_controls(doc, registry, problems)
        return expand(doc, registry, problems)

    def axes(self, spec):
        return []


class MidiKind(ControllerKind):
    """`driver: midi`: a live port or a Standard MIDI File (hapticgraph.devices.midi)."""

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
        from .midi import MidiHub
        return MidiHub(name, spec)


class OscKind(ControllerKind):
    """`driver: osc`: OSC messages over UDP (hapticgraph.devices.osc)."""

    name = "osc"
    controls = ("osc_in",)

    def settings(self):
        return {"port": {"type": "integer", "minimum": 0, "maximum": 65535, "default": 9000,
                         "description": "the UDP port to listen on (0: any free port)"},
                "host": {"type": "string", "minLength": 1, "default": "127.0.0.1",
                         "description": "the address to listen on (0.0.0.0: every network interface)"}}

    def open(self, name, spec, patch):
        from .osc import OscHub
        return OscHub(name, spec)


class ControllerInputKind:
    """The driver of a block played by a controller device (midi_note, midi_cc, osc_in): a tap
    of the driver opened for the device the block names."""

    name = "controller input"
    feeds = (MidiNote, MidiCC, OscIn)

    def kept(self, old, new):
        return old.cls is new.cls and same(old.values, new.values)

    def open(self, inst, base, live_input=None, drivers=None):
        from . import DeviceError
        hub = (drivers or {}).get(inst.values["device"])
        if not hasattr(hub, "tap"):
            raise DeviceError(f"block {inst.name!r} ({inst.cls.type_name}): device {inst.values['device']!r} "
                              f"is not open as a controller")
        return hub.tap(inst)
