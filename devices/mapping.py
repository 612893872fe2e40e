"""Controllers in a patch: the blocks a controller device plays, and the `map:` section.

    devices:
      keys: {driver: midi, port: Keystation}
      ctl:  {driver: osc, port: 9000}
    map:
      - {param: str.tension, cc: 74, min: 1.0e4, max: 2.0e5, curve: exponential, smooth: 0.02}
      - {param: bow.pressure, osc: /bow/pressure, min: 0, max: 2}

`map:` is a shorthand, expanded before the patch is wired (the way Faust's `[midi:ctrl 74]`
metadata binds a slider): each entry becomes ordinary blocks and one connection into the live
parameter (every live parameter is an input port) —
- `cc: N` → a `midi_cc` block (`number: N`, `min`, `max`, `curve`, `smooth`, `channel`);
- `osc: /address` → an `osc_in` block (values 0–1) and a `scale` block onto [min, max].
The new blocks are named `map_BLOCK_PARAM` and report problems at the entry's line. `device:`
names the controller; it may be left out when the patch has exactly one that can serve the entry.
`min` and `max` default to the parameter's declared range.

Blocks with a parameter that `refers="controller"` (midi_note, midi_cc, osc_in) must name a
device whose driver kind lists their type in its `controls`.
"""
import math

from ..graph.source import LDict, LList

NUMBER = {"type": "number"}
ITEM = {
    "type": "object", "required": ["param"], "additionalProperties": False,
    "properties": {
        "param": {"type": "string", "pattern": r"^[A-Za-z_][A-Za-z0-9_]*\.[A-Za-z_][A-Za-z0-9_]*(?![\s\S])",
                  "description": "BLOCK.PARAM: a live parameter"},
        "cc": {"type": "integer", "minimum": 0, "maximum": 127, "description": "a MIDI controller number"},
        "osc": {"type": "string", "pattern": "^/", "description": "an OSC address (values 0–1)"},
        "device": {"type": "string", "description": "the controller device (if the patch has several)"},
        "channel": {"type": "integer", "minimum": 0, "maximum": 16, "description": "MIDI channel; 0: omni"},
        "min": {**NUMBER, "description": "the parameter's value at the controller's minimum"},
        "max": {**NUMBER, "description": "the parameter's value at the controller's maximum"},
        "curve": {"enum": ["linear", "exponential"], "default": "linear"},
        "smooth": {**NUMBER, "minimum": 0, "maximum": 10, "description": "smoothing time constant [s] (cc only)"},
    },
}


def map_schema():
    return {"type": "array", "items": ITEM,
            "description": "bind live parameters to MIDI controllers or OSC addresses"}


def _is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _controllers(devices, drivers, block_type):
    return [n for n, spec in devices.items()
            if isinstance(spec, dict) and block_type in _controls(spec, drivers)]


def _controls(spec, drivers):
    """The block types the device of entry `spec` plays (none if its driver is unknown)."""
    kind = _kind(spec, drivers)
    return kind.controls if kind is not None else ()


def _kind(spec, drivers):
    name = spec.get("driver") if isinstance(spec, dict) else None
    if name is None:
        return next((k for k in drivers.values() if k.default), None)
    return drivers.get(name) if isinstance(name, str) else None


def check_controls(doc, registry, problems):
    """Every block played by a controller names a device that can play it."""
    blocks, devices = doc.get("blocks"), doc.get("devices")
    devices = devices if isinstance(devices, dict) else {}
    for name, spec in (blocks.items() if isinstance(blocks, LDict) else ()):
        cls = registry.types.get(spec.get("type")) if isinstance(spec, LDict) else None
        for pname, param in (cls.params.items() if cls is not None else ()):
            if param.refers != "controller":
                continue
            value, line = spec.get(pname, ""), spec.lines.get(pname, blocks.lines[name])
            can = _controllers(devices, registry.drivers, cls.type_name)
            what = f"block {name!r} ({cls.type_name}): parameter {pname!r}"
            if not isinstance(value, str):
                continue          # the schema says so
            if not value:
                problems.add(line, f"{what}: name the device (one of: {', '.join(can) or 'none declared'})")
            elif value not in devices:
                problems.add(line, f"{what}: no device named {value!r} under devices:")
            elif value not in can:
                driver = devices[value].get("driver") if isinstance(devices[value], dict) else None
                problems.add(line, f"{what}: device {value!r} (driver {driver}) cannot play a {cls.type_name} "
                                   f"block (devices that can: {', '.join(can) or 'none'})")


def expand(doc, registry, problems):
    """The patch document with its `map:` entries turned into blocks and connections (a copy;
    the document is returned as it is when it has no map)."""
    entries = doc.get("map")
    if not isinstance(entries, LList) or not entries:
        return doc
    blocks = doc.get("blocks") if isinstance(doc.get("blocks"), LDict) else LDict()
    new_blocks, new_connect = _copy(blocks, LDict), _copy(doc.get("connect"), LList)
    for entry, line in zip(entries, entries.lines):
        if isinstance(entry, LDict) and isinstance(entry.get("param"), str):
            _expand_one(entry, line, doc, registry, new_blocks, new_connect, problems)
    out = _copy(doc, LDict)
    out["blocks"], out["connect"] = new_blocks, new_connect
    out.lines.setdefault("blocks", 1)
    out.lines.setdefault("connect", 1)
    return out


def _copy(value, kind):
    out = kind(value) if isinstance(value, (dict, list)) else kind()
    out.line = getattr(value, "line", 1)
    src = getattr(value, "lines", None)
    out.lines = (dict(src) if isinstance(src, dict) else list(src)) if src is not None else out.lines
    return out


def _target(entry, line, doc, registry, problems):
    """(block name, Param) of the entry's live parameter, or None (reported)."""
    text = entry["param"]
    block, _, pname = text.partition(".")
    spec = doc.get("blocks", {}).get(block) if isinstance(doc.get("blocks"), dict) else None
    where = f"map: param {text!r}"
    if not isinstance(spec, dict):
        problems.add(line, f"{where}: no block named {block!r} under blocks:")
        return None
    cls = registry.types.get(spec.get("type"))
    if cls is None:
        return None           # an unknown type, reported with the block
    param = cls.params.get(pname)
    if param is None or param.internal or not param.live:
        live = [n for n, p in cls.params.items() if p.live and not p.internal]
        problems.add(line, f"{where}: block {block!r} ({cls.type_name}) has no live parameter {pname!r} "
                           f"(its live parameters: {', '.join(live) or 'none'})")
        return None
    return block, param


def _range(entry, line, param, problems):
    """(min, max) of the entry, defaulting to the parameter's range; None if wrong (reported)."""
    where = f"map: param {entry['param']!r}"
    lo = entry.get("min", param.minimum if param.minimum is not None else param.above)
    hi = entry.get("max", param.maximum if param.maximum is not None else param.below)
    if not (_is_num(lo) and _is_num(hi)):
        problems.add(line, f"{where}: give `min` and `max` (the parameter has no declared range)")
        return None
    ok = True
    for key, v in (("min", lo), ("max", hi)):
        low = param.minimum if param.minimum is not None else param.above
        high = param.maximum if param.maximum is not None else param.below
        if (low is not None and (v < low or (param.above is not None and v <= param.above))) or \
           (high is not None and (v > high or (param.below is not None and v >= param.below))):
            unit = f" {param.unit}" if param.unit else ""
            problems.add(entry.lines.get(key, line), f"{where}: {key} {v:g}{unit} is outside the parameter's "
                                                     f"range [{low}, {high}]{unit}")
            ok = False
    if entry.get("curve") == "exponential" and not lo * hi > 0:
        problems.add(entry.lines.get("curve", line), f"{where}: an exponential curve needs min and max "
                                                     f"non-zero and of one sign")
        ok = False
    return (float(lo), float(hi)) if ok else None


def _device(entry, line, doc, registry, block_type, problems):
    devices = doc.get("devices") if isinstance(doc.get("devices"), dict) else {}
    can = _controllers(devices, registry.drivers, block_type)
    where = f"map: param {entry['param']!r}"
    name = entry.get("device")
    if name is None:
        if len(can) == 1:
            return can[0]
        problems.add(line, f"{where}: " + (f"say which `device:` plays it ({', '.join(can)})" if can else
                                           f"no device under devices: can play {block_type} blocks (a "
                                           f"{'midi' if block_type == 'midi_cc' else 'osc'} device)"))
        return None
    if name not in can:
        problems.add(entry.lines.get("device", line), f"{where}: device {name!r} cannot play a {block_type} "
                                                      f"(devices that can: {', '.join(can) or 'none'})")
        return None
    return name


def _expand_one(entry, line, doc, registry, blocks, connect, problems):
    where = f"map: param {entry['param']!r}"
    if ("cc" in entry) == ("osc" in entry):
        problems.add(line, f"{where}: give either `cc: NUMBER` or `osc: /address`")
        return
    if "osc" in entry and "smooth" in entry:
        problems.add(entry.lines.get("smooth", line), f"{where}: `smooth` applies to a cc mapping only")
    target = _target(entry, line, doc, registry, problems)
    block_type = "midi_cc" if "cc" in entry else "osc_in"
    device = _device(entry, line, doc, registry, block_type, problems)
    span = _range(entry, line, target[1], problems) if target is not None else None
    if target is None or device is None or span is None:
        return
    block, param = target
    name = f"map_{block}_{param.name}"
    while name in blocks:
        name += "_"
    curve = entry.get("curve", "linear")
    if block_type == "midi_cc":
        spec = {"type": "midi_cc", "device": device, "number": entry["cc"], "channel": entry.get("channel", 0),
                "min": span[0], "max": span[1], "curve": curve, "smooth": entry.get("smooth", 0.0)}
        _add(blocks, name, spec, entry, line)
        source = name
    else:
        _add(blocks, name, {"type": "osc_in", "device": device, "address": entry["osc"]}, entry, line)
        source = name + "_scale"
        _add(blocks, source, {"type": "scale", "in_range": [0.0, 1.0], "out_range": list(span), "curve": curve},
             entry, line)
        connect.append(f"{name}.out -> {source}.in")
        connect.lines.append(line)
    connect.append(f"{source}.out -> {block}.{param.name}")
    connect.lines.append(line)


def _add(blocks, name, values, entry, line):
    spec = LDict(values)
    spec.line = line
    spec.lines = {k: entry.lines.get(k, line) for k in values}
    blocks[name] = spec
    blocks.lines[name] = line


__all__ = ["ITEM", "check_controls", "expand", "map_schema"]
