"""Devices: the drivers that bind a patch to the world (simulated haptic device, HID, replay, WAV files)."""
import difflib
import math
import os
import sys

from .files import WavInput
from .hid import HidDriver
from .simulated import SimulatedDevice, SimulatedHaptic


class DeviceError(Exception):
    pass


def _replay(name, spec, patch):
    from .record import ReplayDevice
    return ReplayDevice(name, spec, patch)


def _hid(name, spec, patch):
    # the profile the loader attached (its file relative to the patch) unless a setting names another
    profile = getattr(spec, "hid_profile", None)
    return HidDriver(name, spec, profile=profile, base=os.getcwd())


DRIVERS = {"simulated": SimulatedDevice, "hid": HidDriver, "replay": _replay}
def _simulated(name, spec, patch):
    from ..graph.patch import device_axes
    return SimulatedDevice(name, spec, axes=device_axes(patch.devices, name))


_OPEN = {"simulated": _simulated, "hid": _hid, "replay": _replay}


# -- device settings (`--device NAME=DRIVER,KEY=VALUE,...`) ---------------------------------------------
def driver_settings():
    """Each driver's settings, name -> JSON Schema, from the patch schema's device entry."""
    from ..graph.schema import device_schema
    out = {}
    for clause in device_schema()["allOf"]:
        kind = clause["if"]["properties"]["driver"]["const"]
        out[kind] = {k: v for k, v in clause["then"]["properties"].items() if k != "driver"}
    return out


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
    import jsonschema
    from ..graph.errors import Collector
    from ..graph.source import parse_value
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
        try:
            jsonschema.validate(value, schema)
        except jsonschema.ValidationError as exc:
            raise DeviceError(f"{where}: {key}={raw}: {exc.message}") from None
        settings[key] = value
    return name, Choice(driver, settings, text)


def _did_you_mean(word, options):
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _entry(name, spec, choice, accepted, notes):
    """The device entry a driver opens: the file's, with the command line's choice applied; keys
    only another driver reads are left out, with a note."""
    file_driver = spec.get("driver", "simulated")
    if choice is None:
        return file_driver, spec
    kind, settings = (choice, {}) if isinstance(choice, str) else (choice.driver, choice.settings)
    if kind not in accepted:
        raise DeviceError(f"device {name!r}: unknown driver {kind!r}; the drivers are: {', '.join(sorted(accepted))}")
    if kind == file_driver and not settings:
        return kind, spec
    keep = accepted[kind]
    ignored = [k for k in spec if k != "driver" and k not in keep]
    entry = type(spec)({k: v for k, v in spec.items() if k not in ignored})
    for attr in ("line", "lines"):
        if hasattr(spec, attr):
            setattr(entry, attr, getattr(spec, attr))
    if "profile" not in settings and hasattr(spec, "hid_profile"):
        entry.hid_profile = spec.hid_profile
    entry.update(settings)
    entry["driver"] = kind
    if ignored and isinstance(choice, Choice):
        notes.append(f"device {name!r} ({kind}): ignoring {', '.join(ignored)} of the patch's "
                     f"{file_driver} entry (the {kind} driver does not read them)")
    return kind, entry


def open_drivers(patch, choices=None, live_input=None, notes=None):
    """A Driver for each device entry of a patch (`choices`, name → a driver name or a Choice
    with settings, overrides the file), and one for each block fed from a file (audio_in) — or,
    with `live_input` (play gives it), a live input driver `live_input(block)` for an audio_in
    block with no file. A device entry's `file` (a replay take) is relative to the patch.
    Notes (settings ignored for another driver) are appended to `notes`, or printed on stderr."""
    choices = dict(choices or {})
    unknown = set(choices) - set(patch.devices)
    if unknown:
        raise DeviceError(f"--device: the patch declares no device named {', '.join(sorted(unknown))} "
                          f"(its devices: {', '.join(patch.devices) or 'none'})")
    accepted = driver_settings()
    said = [] if notes is None else notes
    drivers = {}
    base = os.path.dirname(os.path.abspath(patch.file))
    for name, spec in patch.devices.items():
        kind, spec = _entry(name, spec, choices.get(name), accepted, said)
        if notes is None:            # said before the device opens (which may fail)
            for line in said:
                print(f"hapticgraph: note: {line}", file=sys.stderr)
            said.clear()
        factory = _OPEN.get(kind)
        if factory is None:
            raise DeviceError(f"device {name!r}: driver {kind!r} is not available in this build "
                              f"(available: {', '.join(sorted(_OPEN))})")
        choice = choices.get(name)
        from_cli = isinstance(choice, Choice) and "file" in choice.settings
        if isinstance(spec.get("file"), str) and not from_cli:
            spec = {**spec, "file": os.path.join(base, spec["file"])}
        drivers[name] = factory(name, spec, patch)
    for inst in patch.blocks.values():
        if inst.cls.type_name == "audio_in":
            if not inst.values["file"] and live_input is not None:
                drivers[inst.name] = live_input(inst)
                continue
            if not inst.values["file"]:
                raise DeviceError(f"block {inst.name!r} (audio_in): no file given, and live input needs `play`")
            path = os.path.join(base, inst.values["file"])
            try:
                drivers[inst.name] = WavInput(path, inst.values["channel"], inst.values["loop"])
            except (OSError, ValueError) as exc:
                raise DeviceError(f"block {inst.name!r} (audio_in): cannot read {inst.values['file']!r}: {exc}") from None
    return drivers


__all__ = ["DRIVERS", "Choice", "DeviceError", "SimulatedDevice", "SimulatedHaptic", "WavInput", "open_drivers",
           "parse_choice"]
