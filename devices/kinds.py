"""Driver kinds: all that hapticgraph knows about each `driver:` of a device entry, in one place.

The patch loader (graph/) names no driver: the top floor (hapticgraph/__init__.py) hands it KINDS,
and it asks each kind, through the protocol hapticgraph.graph.registry documents, for
- `name`, and `default` (the driver of an entry with no `driver:` key);
- `settings()`: the keys of its device entry, key -> JSON Schema (the patch schema, editor
  completion and `--device NAME=DRIVER,KEY=VALUE` all read it), `required`, and `closed` (other
  keys refused);
- `check(name, spec, base, problems)`: what a schema cannot say (a HID profile parsed, reported at
  its own FILE:LINE and attached to the entry; max_force within the device's bound; keyframes in
  time order);
- `axes(spec)`: the device's extra columns (axes, buttons), each an output port of its block.
The engine side (hapticgraph.devices) asks a kind to `open(name, spec, patch)` its Driver, to
`override(spec, settings)` an entry from the command line, whether a running driver is `kept`
across a reload, and a take names a kind's `model` (the block type that simulates the device).
A block fed by its own driver (audio_in: a WAV file, or the sound card's live input) is matched by
the block type an input kind `feeds`.

This module is imported whenever a patch is loaded, so it stays light: each driver's code is
imported when it is opened.
"""
import math
import os

from ..blocks.device import Haptic
from ..blocks.sources import AudioIn
from ..graph.errors import PatchError
from ..graph.source import LList
from .hid_profiles import MAX_FORCE, find_profile, load_profile, profile_of, shipped_profiles

SIMULATED_MAX_FORCE = 50.0   # N: the simulated device's bound (see hapticgraph.devices.simulated)
NUMBER = {"type": "number"}
MAX_FORCE_SETTING = {**NUMBER, "exclusiveMinimum": 0, "maximum": MAX_FORCE, "default": 4.0,
                     "description": "every force sent to the device is clamped to this [N]"}


def same(a, b):
    """Deep equality of entries and parameter values (dicts, lists, numpy arrays, numbers, text)."""
    import numpy as np
    seq = (list, tuple, np.ndarray)
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype != object and b.dtype != object:
        return a.shape == b.shape and bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, seq) and isinstance(b, seq):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, (dict,) + seq) or isinstance(b, (dict,) + seq):
        return False
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001 - not comparable: treat as changed
        return False


def _is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check_limit(spec, name, bound, what, problems):
    """An entry's max_force may not exceed its device's bound (a number > 0 is the schema's to check)."""
    value = spec.get("max_force")
    if _is_num(value) and 0 < value <= MAX_FORCE and value > bound:
        problems.add(spec.lines.get("max_force", spec.line),
                     f"device {name!r}: max_force {value:g} N is above {what}, {bound:g} N")


class DriverKind:
    """One `driver:` (see the module's doc); the defaults suit a driver with nothing to check."""

    name = ""
    default = False
    required = ()
    closed = True
    model = None              # the block type the driver substitutes for the patch's, if any
    model_columns = ()        # the columns that model reads before the device's axes

    def settings(self):
        return {"max_force": MAX_FORCE_SETTING}

    def check(self, name, spec, base, problems):
        pass

    def axes(self, spec):
        """The axes an entry lists (`axes: [...]`) and the keys its script's keyframes carry
        besides t and x, in order of appearance."""
        listed = spec.get("axes")
        axes = [a for a in listed if isinstance(a, str)] if isinstance(listed, list) else []
        script = spec.get("script")
        for key in script if isinstance(script, list) else []:
            if isinstance(key, dict):
                axes += [k for k in key if k not in SimulatedKind.RESERVED and k not in axes]
        return axes

    def override(self, spec, settings, drop=()):
        """The entry `spec` (less the keys in `drop`) with the command line's settings applied."""
        entry = type(spec)({k: v for k, v in spec.items() if k not in drop})
        for attr in ("line", "lines"):
            if hasattr(spec, attr):
                setattr(entry, attr, getattr(spec, attr))
        entry.update(settings)
        entry["driver"] = self.name
        return entry

    def kept(self, old, new):
        """Whether the driver opened for entry `old` keeps running when a reload brings `new`."""
        return same(dict(old), dict(new))

    def open(self, name, spec, patch):
        raise NotImplementedError


class SimulatedKind(DriverKind):
    """`driver: simulated`, the default: a hand on a model of the device (hapticgraph.devices.simulated)."""

    name = "simulated"
    default = True
    model_columns = ("hand_x", "hand_v")
    # keyframe keys that are not extra axes: the time and the haptic block's own ports and settings
    RESERVED = ("t", *(p.name for p in Haptic.outputs + Haptic.inputs),
                *(n for n, p in Haptic.params.items() if not p.internal))

    @property
    def model(self):
        from .simulated import SimulatedHaptic
        return SimulatedHaptic

    def settings(self):
        keyframe = {"type": "object", "required": ["t"],
                    "propertyNames": {"pattern": r"^[A-Za-z_][A-Za-z0-9_]*(?![\s\S])",
                                      "not": {"enum": [k for k in self.RESERVED if k not in ("t", "x")]}},
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
        _check_limit(spec, name, SIMULATED_MAX_FORCE, "the simulated device's bound", problems)
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
        from ..graph.patch import device_axes
        from .simulated import SimulatedDevice
        # the axes the patch sees: those of the file's entry, whichever driver it was written for
        return SimulatedDevice(name, spec, axes=device_axes(patch.devices, name, kinds_of(patch)))


class HidKind(DriverKind):
    """`driver: hid`: a USB HID device described by a profile (hapticgraph.devices.hid_profiles)."""

    name = "hid"
    required = ("profile",)

    def settings(self):
        usb_id = {"type": "integer", "minimum": 0, "maximum": 0xFFFF}
        return {**super().settings(),
                "profile": {"type": "string", "minLength": 1,
                            "description": "a shipped HID profile's name (gamepad, mouse, haptic_1dof) "
                                           "or a profile .yaml file beside the patch"},
                "vendor_id": {**usb_id, "description": "USB vendor id, if not the profile's"},
                "product_id": {**usb_id, "description": "USB product id, if not the profile's"},
                "serial": {"type": "string", "description": "open the device with this serial number"},
                "path": {"type": "string", "minLength": 1,
                         "description": "open the device at this hidapi path (`hapticgraph devices` lists them)"}}

    def check(self, name, spec, base, problems):
        """Load the entry's profile, report its problems (an unknown profile at the patch's line, a
        bad one at the profile's FILE:LINE) and attach it to the entry as `hid_profile`."""
        ref = spec.get("profile")
        if not isinstance(ref, str):
            return
        line = spec.lines.get("profile", spec.line)
        path = find_profile(ref, base)
        if path is None:
            known = ", ".join(shipped_profiles()) or "none"
            problems.add(line, f"device {name!r}: no HID profile {ref!r} (shipped: {known}; "
                               f"or a .yaml file beside the patch)")
            return
        try:
            spec.hid_profile = load_profile(path)
        except PatchError as exc:
            problems.add(line, f"device {name!r}: HID profile {ref!r} has {len(exc.problems)} problem(s), "
                               f"listed at its own file and lines")
            problems.problems.extend(exc.problems)
            return
        profile = spec.hid_profile
        if profile.output is not None:
            _check_limit(spec, name, profile.max_force, f"the bound its profile {profile.name!r} states", problems)

    def axes(self, spec):
        profile = profile_of(spec)
        return list(profile.ports) if profile is not None else []

    def override(self, spec, settings, drop=()):
        entry = super().override(spec, settings, drop)
        if "profile" not in settings and hasattr(spec, "hid_profile"):
            entry.hid_profile = spec.hid_profile
        return entry

    def open(self, name, spec, patch):
        from .hid import HidDriver
        # the profile the loader attached (its file relative to the patch) unless a setting names another
        return HidDriver(name, spec, profile=getattr(spec, "hid_profile", None), base=os.getcwd())


class ReplayKind(DriverKind):
    """`driver: replay`: a device fed from a take (hapticgraph.devices.record); other keys of the
    entry (written for the driver it replays) are kept."""

    name = "replay"
    required = ("file",)
    closed = False

    def settings(self):
        return {**super().settings(), "file": {"type": "string"}}

    def open(self, name, spec, patch):
        from .record import ReplayDevice
        return ReplayDevice(name, spec, patch)


class AudioInputKind:
    """The driver of a block the sound enters by (audio_in): its WAV `file` beside the patch, or
    with none, while playing, a live input channel of the sound card (`live_input(block)`)."""

    name = "audio input"
    feeds = AudioIn

    def kept(self, old, new):
        return old.cls is new.cls and same(old.values, new.values)

    def open(self, inst, base, live_input=None, drivers=None):
        from . import DeviceError
        from .files import WavInput
        what = f"block {inst.name!r} ({inst.cls.type_name})"
        if not inst.values["file"]:
            if live_input is not None:
                return live_input(inst)
            raise DeviceError(f"{what}: no file given, and live input needs `play`")
        path = os.path.join(base, inst.values["file"])
        try:
            return WavInput(path, inst.values["channel"], inst.values["loop"])
        except (OSError, ValueError) as exc:
            raise DeviceError(f"{what}: cannot read {inst.values['file']!r}: {exc}") from None


from .controller_kinds import ControllerInputKind, ControllerKind, MidiKind, OscKind, SerialKind  # noqa: E402,F401


KINDS = (SimulatedKind(), HidKind(), ReplayKind(), SerialKind(), MidiKind(), OscKind())
INPUTS = (AudioInputKind(), ControllerInputKind())


def driver_kinds():
    """The device drivers, name -> kind (what the top floor hands the loader)."""
    return {kind.name: kind for kind in KINDS}


def kinds_of(patch):
    """The driver kinds a patch was loaded with."""
    registry = getattr(patch, "registry", None)
    return getattr(registry, "drivers", None) or driver_kinds()


def input_kind(cls):
    """The kind that feeds blocks of type `cls` from outside the patch, or None."""
    return next((k for k in INPUTS if issubclass(cls, k.feeds)), None)


__all__ = ["KINDS", "INPUTS", "SIMULATED_MAX_FORCE", "DriverKind", "AudioInputKind", "driver_kinds", "input_kind",
           "kinds_of", "same"]
