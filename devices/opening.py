"""Opening a patch's drivers: a driver for each device entry (the kind its `driver:` names in the
table, or the one `--device NAME=DRIVER,KEY=VALUE` chooses) and for each block fed from outside."""
import difflib
import math
import os
import sys

from ..graph.entries import driver_of
from ..graph.errors import Collector
from ..graph.source import parse_value
from .errors import DeviceError
from .table import driver_kinds, input_kind, kinds_of


# -- device settings (`--device NAME=DRIVER,KEY=VALUE,...`) ---------------------------------------------
def driver_settings(kinds=None):
    """Each driver's settings, name -> {key: JSON Schema}, as its kind declares them."""
    return {name: kind.settings() for name, kind in (kinds or driver_kinds()).items()}


def _scalar(schema):
    kinds = schema.get("type")
    return kinds in ("number", "integer", "string", "boolean")


class Choice:
    """A device's driver chosen on the command line, with settings that override its entry's."""

    def __init__(self, driver, settings=None, text=None):
        self.driver, self.settings, self.text = driver, dict(settings or {}), text

    def __repr__(self):
        return f"Choice({self.driver!r}, {self.settings!r})"


def parse_choice(text):
    """`NAME=DRIVER[,KEY=VALUE...]` -> (name, Choice). Each VALUE is read as a YAML scalar (text
    for text settings) and checked against the driver's setting schema, like the patch file's."""
    name, sep, rest = text.partition("=")
    name = name.strip()
    parts = [p.strip() for p in rest.split(",")]
    driver = parts[0] if parts else ""
    if not sep or not name or not driver:
        raise DeviceError(f"--device {text!r}: expected NAME=DRIVER[,KEY=VALUE...]")
    accepted = driver_settings()
    if driver not in accepted:
        raise DeviceError(f"--device {text!r}: unknown driver {driver!r}{_did_you_mean(driver, accepted)}; "
                          f"the drivers are: {', '.join(sorted(accepted))}")
    allowed = {k: v for k, v in accepted[driver].items() if _scalar(v)}
    where = f"device {name!r} ({driver})"
    settings = {}
    for part in parts[1:]:
        key, eq, raw = part.partition("=")
        key = key.strip()
        if not eq or not key:
            raise DeviceError(f"--device {text!r}: {part!r} is not a setting KEY=VALUE")
        if key not in allowed:
            raise DeviceError(f"{where}: unknown setting {key!r}{_did_you_mean(key, allowed)}; the {driver} "
                              f"driver accepts: {', '.join(allowed)}")
        schema = allowed[key]
        if schema.get("type") == "string":
            value = raw.strip()
        else:
            problems = Collector("--device")     # the file's guards: budgets, no tags, finite numbers
            ok, value = parse_value(raw, problems, 1)
            if not ok:
                raise DeviceError(f"{where}: {key}={raw}: {problems.problems[0].message}")
        if isinstance(value, float) and not math.isfinite(value):
            raise DeviceError(f"{where}: {key}={raw}: expected a finite number")
        import jsonschema      # heavy: only when the command line sets a device's setting
        try:
            jsonschema.validate(value, schema)
        except jsonschema.ValidationError as exc:
            raise DeviceError(f"{where}: {key}={raw}: {exc.message}") from None
        settings[key] = value
    return name, Choice(driver, settings, text)


def _did_you_mean(word, options):
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _entry(name, spec, choice, kinds, notes):
    """The device entry a driver opens: the file's, with the command line's choice applied; keys
    only another driver reads are left out, with a note."""
    file_kind = driver_of(spec, kinds)
    if choice is None:
        return file_kind, spec
    kind_name, settings = (choice, {}) if isinstance(choice, str) else (choice.driver, choice.settings)
    kind = kinds.get(kind_name)
    if kind is None:
        raise DeviceError(f"device {name!r}: unknown driver {kind_name!r}; the drivers are: {', '.join(sorted(kinds))}")
    if kind is file_kind and not settings:
        return kind, spec
    keep = kind.settings()
    ignored = [k for k in spec if k != "driver" and k not in keep]
    entry = kind.override(spec, settings, drop=ignored)
    if ignored and isinstance(choice, Choice):
        file_name = file_kind.name if file_kind is not None else spec.get("driver")
        notes.append(f"device {name!r} ({kind.name}): ignoring {', '.join(ignored)} of the patch's "
                     f"{file_name} entry (the {kind.name} driver does not read them)")
    return kind, entry


def check_choices(patch, choices):
    """DeviceError unless every device the command line chose a driver for is one of the patch's."""
    unknown = set(choices or ()) - set(patch.devices)
    if unknown:
        raise DeviceError(f"--device: the patch declares no device named {', '.join(sorted(unknown))} "
                          f"(its devices: {', '.join(patch.devices) or 'none'})")


def open_drivers(patch, choices=None, live_input=None, notes=None, running=None):
    """A Driver for each device entry of a patch (`choices`, name → a driver name or a Choice
    with settings, overrides the file), and one for each block fed from outside (audio_in: its
    file or — with `live_input` (play gives it) — a live input driver `live_input(block)`). A
    device entry's `file` (a replay take) is relative to the patch. `running`: drivers already
    open (a reload keeps them) that a block fed from outside may play from (a controller's
    hub). Notes (settings ignored for another driver) are appended to `notes`, or printed on
    stderr."""
    choices = dict(choices or {})
    check_choices(patch, choices)
    kinds = kinds_of(patch)
    said = [] if notes is None else notes
    drivers = {}
    base = os.path.dirname(os.path.abspath(patch.file))
    for name, spec in patch.devices.items():
        kind, spec = _entry(name, spec, choices.get(name), kinds, said)
        if notes is None:            # said before the device opens (which may fail)
            for line in said:
                print(f"hapticgraph: note: {line}", file=sys.stderr)
            said.clear()
        if kind is None:
            raise DeviceError(f"device {name!r}: driver {spec.get('driver')!r} is not available in this build "
                              f"(available: {', '.join(sorted(kinds))})")
        choice = choices.get(name)
        from_cli = isinstance(choice, Choice) and "file" in choice.settings
        if isinstance(spec.get("file"), str) and not from_cli:
            spec = {**spec, "file": os.path.join(base, spec["file"])}
        drivers[name] = kind.open(name, spec, patch)
    for inst in patch.blocks.values():
        feeder = input_kind(inst.cls)
        if feeder is not None:
            drivers[inst.name] = feeder.open(inst, base, live_input, {**(running or {}), **drivers})
    return drivers


__all__ = ["Choice", "check_choices", "driver_settings", "open_drivers", "parse_choice"]
