"""What a driver kind is: all that hapticgraph knows about one `driver:` of a device entry before
the device runs, and about a kind of block fed from outside the patch (audio_in, a controller's
blocks). The kinds are found in the entry-point groups hapticgraph.devices.table reads; each
built-in one lives beside its driver (`simulated_kind.py` beside `simulated.py`, ...).

The patch loader (graph/) names no driver: it is handed the table and asks each DriverKind for
- `name`, and `default` (the driver of an entry with no `driver:` key);
- `settings()`: the keys of its device entry, key -> JSON Schema (the patch schema, editor
  completion and `--device NAME=DRIVER,KEY=VALUE` all read it), `required`, and `closed` (other
  keys refused);
- `check(name, spec, base, problems)`: what a schema cannot say (a profile parsed and reported at
  its own FILE:LINE, then `attach`ed to the entry; max_force within the device's bound);
- `axes(spec)`: the device's extra columns (axes, buttons), each an output port of its block;
- `sections()` and `prepare(doc, registry, problems)`: top-level sections of a patch it adds, and
  their checks and shorthands (the controllers' `map:`).
The engine side (hapticgraph.devices) asks a kind to `open(name, spec, patch)` its Driver, to
`override(spec, settings)` an entry from the command line, whether a running driver is `kept`
across a reload, and a take names a kind's `model` (the block type that simulates the device).

A kind module is imported whenever a patch is loaded, so it stays light: `open` imports its
driver's module (which brings the engine, numpy, and for some hidapi or soundfile) when called.
"""
import numpy as np

from ..blocks.device import Haptic
from ..graph.source import LDict
from .limits import FORCE_CEILING

NUMBER = {"type": "number"}
MAX_FORCE_SETTING = {**NUMBER, "exclusiveMinimum": 0, "maximum": FORCE_CEILING, "default": 4.0,
                     "description": "every force sent to the device is clamped to this [N]"}
USB_ID = {"type": "integer", "minimum": 0, "maximum": 0xFFFF}


def match_setting(description, **properties):
    """The schema of a `match:` key naming a connected device: by USB vendor and product ids, a
    part of its name, and which of several (`index`), with a kind's own `properties` besides."""
    return {"type": "object", "minProperties": 1, "additionalProperties": False, "description": description,
            "properties": {"vendor": {**USB_ID, "description": "USB vendor id"},
                           "product": {**USB_ID, "description": "USB product id"},
                           "name": {"type": "string", "minLength": 1, "description": "a part of the device's name"},
                           **properties,
                           "index": {"type": "integer", "minimum": 0,
                                     "description": "which of the matching devices (0: the first)"}}}


# keyframe keys of a script that are not extra axes: the time and the haptic block's own ports and settings
SCRIPT_RESERVED = ("t", *(p.name for p in Haptic.outputs + Haptic.inputs),
                   *(n for n, p in Haptic.params.items() if not p.internal))


def same(a, b):
    """Deep equality of entries and parameter values (dicts, lists, numpy arrays, numbers, text)."""
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


def attach(spec, key, value):
    """Keep what a kind's `check` parsed (a profile) with the device entry it came from."""
    setattr(spec, key, value)


def attached(spec, key):
    """What a kind's `check` attached to an entry read from a patch (an LDict), or None: an entry
    made in code or on the command line carries nothing."""
    return vars(spec).get(key) if isinstance(spec, LDict) else None


def listed_axes(spec):
    """The axes an entry lists (`axes: [...]`) and the keys its script's keyframes carry besides
    t and x, in order of appearance."""
    listed = spec.get("axes")
    axes = [a for a in listed if isinstance(a, str)] if isinstance(listed, list) else []
    script = spec.get("script")
    for key in script if isinstance(script, list) else []:
        if isinstance(key, dict):
            axes += [k for k in key if k not in SCRIPT_RESERVED and k not in axes]
    return axes


class DriverKind:
    """One `driver:` (see the module's doc); the defaults suit a driver with nothing to check.
    A plugin subclasses it and registers the class in the entry-point group `hapticgraph.drivers`
    under its `name`."""

    name = ""
    default = False
    required = ()
    closed = True
    model = None              # the block type the driver substitutes for the patch's, if any
    model_columns = ()        # the columns that model reads before the device's axes
    controls = ()             # the block types a controller device plays (hapticgraph.devices.controller_kind)
    carries = ()              # what `check` attaches to an entry (kept by `override`)

    def settings(self):
        return {"max_force": MAX_FORCE_SETTING}

    def check(self, name, spec, base, problems):
        pass

    def axes(self, spec):
        return listed_axes(spec)

    def sections(self):
        """Top-level sections of a patch this driver adds, key -> JSON Schema."""
        return {}

    def prepare(self, doc, registry, problems):
        """The document after this driver's checks and shorthands of its sections."""
        return doc

    def override(self, spec, settings, drop=()):
        """The entry `spec` (less the keys in `drop`) with the command line's settings applied;
        what `check` attached stays unless a setting replaces the key it came from."""
        entry = type(spec)({k: v for k, v in spec.items() if k not in drop})
        if isinstance(spec, LDict):
            entry.line, entry.lines = spec.line, spec.lines
            for key, source in self.carries:
                if source not in settings and attached(spec, key) is not None:
                    attach(entry, key, attached(spec, key))
        entry.update(settings)
        entry["driver"] = self.name
        return entry

    def kept(self, old, new):
        """Whether the driver opened for entry `old` keeps running when a reload brings `new`."""
        return same(dict(old), dict(new))

    def open(self, name, spec, patch):
        """The Driver of device `name` (entry `spec`) of `patch`; DeviceError if it cannot open."""
        raise NotImplementedError(f"driver kind {self.name!r} opens no driver")


class InputKind:
    """A kind of block fed from outside by a driver of its own (audio_in: a WAV file or the sound
    card's live input; a controller's blocks: a tap of their device's hub). Registered in the
    entry-point group `hapticgraph.inputs`; `feeds`: the block types it feeds."""

    name = ""
    feeds = ()

    def kept(self, old, new):
        """Whether the driver of block instance `old` keeps running when a reload brings `new`."""
        return old.cls is new.cls and same(old.values, new.values)

    def open(self, inst, base, live_input=None, drivers=None):
        """The Driver of block instance `inst` (`base`: the patch's folder; `live_input(inst)`:
        play's live input driver; `drivers`: the device drivers opened so far)."""
        raise NotImplementedError(f"input kind {self.name!r} opens no driver")


__all__ = ["MAX_FORCE_SETTING", "NUMBER", "SCRIPT_RESERVED", "USB_ID", "match_setting", "DriverKind", "InputKind", "attach", "attached",
           "listed_axes", "same"]
