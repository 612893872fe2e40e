"""Controllers in a patch: the blocks a controller device plays, and the `map:` section.

    devices:
      keys: {driver: midi, port: Keystation}
      ctl:  {driver: osc, port: 9000}
    map:
      - {param: str.tension, cc: 74, min: 1.0e4, max: 2.0e5, curve: exponential, smooth: 0.02}
      - {param: bow.pressure, osc: /bow/pressure, min: 0, max: 2}
      - {param: sheet.mass, axis: stick.x, min: 0.001, max: 0.01, curve: exponential, hold: stick.button1}

`map:` is a shorthand, expanded before the patch is wired (the way Faust's `[midi:ctrl 74]`
metadata binds a slider): each entry becomes ordinary blocks and one connection into the live
parameter (every live parameter is an input port) —
- `cc: N` → a `midi_cc` block (`number: N`, `min`, `max`, `curve`, `smooth`, `channel`);
- `osc: /address` → an `osc_in` block (values 0–1) and a `scale` block onto [min, max];
- `axis: DEVICE.INPUT` → a `scale` block from the input's range onto [min, max], fed by the
  `haptic` block of that device (one is added, `map_DEVICE`, when the patch has none). DEVICE
  names an entry under devices: (a HID, evdev or simulated device; a `haptic` block's name works
  too) and INPUT one of its inputs: x, v or an axis or button its driver names (y, rz, throttle,
  hat_x, button1, ...). The input's range is `range: [lo, hi]`, else −1 … 1 for a centred axis
  (x, y, z, rx, ry, rz, dial, wheel, rudder, steering, hats, v) and 0 … 1 for the rest
  (throttle, slider, pedals, buttons), as the HID and evdev drivers normalise them.
  `hold: DEVICE.BUTTON` is Cymatic's suppress-then-jump button: while it is held the parameter
  keeps its value, on release it jumps to where the axis is (a `sample_hold` block,
  `map_BLOCK_PARAM_hold`).
The new blocks are named `map_BLOCK_PARAM` and report problems at the entry's line. `device:`
names the controller; it may be left out when the patch has exactly one that can serve the entry.
`min` and `max` default to the parameter's declared range.

Blocks with a parameter that `refers="controller"` (midi_note, midi_cc, osc_in) must name a
device whose driver kind lists their type in its `controls`.
"""
import math

from ..graph.source import LDict, LList

NUMBER = {"type": "number"}
PORT_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*\.[A-Za-z_][A-Za-z0-9_]*(?![\s\S])"
# inputs the HID and evdev drivers give −1 … 1 (hapticgraph.devices.hid_usages.CENTRED, evdev_layout.CENTRED)
CENTRED = ("x", "y", "z", "rx", "ry", "rz", "v", "vx", "vy", "vz", "vbrx", "vbry", "vbrz", "dial", "wheel", "rudder",
           "steering", "aileron", "elevator")
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
        "axis": {"type": "string", "pattern": PORT_PATTERN,
                 "description": "DEVICE.INPUT: a device's axis or button (stick.x, wheel.throttle, pad.button3)"},
        "hold": {"type": "string", "pattern": PORT_PATTERN,
                 "description": "DEVICE.BUTTON: while held the parameter keeps its value; on release it jumps"},
        "range": {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 2,
                  "description": "the axis's own range [lo, hi] (default −1 … 1 centred, 0 … 1 otherwise)"},
    },
}


def map_schema():
    return {"type": "array", "items": ITEM,
            "description": "bind live parameters to MIDI controllers, OSC addresses or device axes"}


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
        cls = registry.lookup(spec.get("type")) if isinstance(spec, LDict) else None
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
    cls = registry.lookup(spec.get("type"))
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
    if sum(k in entry for k in ("cc", "osc", "axis")) != 1:
        problems.add(line, f"{where}: give either `cc: NUMBER`, `osc: /address` or `axis: DEVICE.INPUT`")
        return
    if "axis" in entry:
        _expand_axis(entry, line, where, doc, registry, blocks, connect, problems)
        return
    for key in ("hold", "range"):
        if key in entry:
            problems.add(entry.lines.get(key, line), f"{where}: `{key}` applies to an axis mapping only")
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


def _expand_axis(entry, line, where, doc, registry, blocks, connect, problems):
    for key in ("smooth", "channel", "device"):
        if key in entry:
            what = "a cc or osc mapping (an axis names its device)" if key == "device" else "a cc mapping"
            problems.add(entry.lines.get(key, line), f"{where}: `{key}` applies to {what} only")
    target = _target(entry, line, doc, registry, problems)
    axis = _device_port(entry, "axis", line, where, doc, registry, problems)
    hold = _device_port(entry, "hold", line, where, doc, registry, problems) if "hold" in entry else None
    span = _range(entry, line, target[1], problems) if target is not None else None
    if target is None or axis is None or span is None or ("hold" in entry and hold is None):
        return
    block, param = target
    lo_hi = entry.get("range") or ([-1.0, 1.0] if _centred(axis[1]) else [0.0, 1.0])
    if lo_hi[0] == lo_hi[1]:
        problems.add(entry.lines.get("range", line), f"{where}: range needs two different values")
        return
    name = _free(blocks, f"map_{block}_{param.name}")
    _add(blocks, name, {"type": "scale", "in_range": [float(v) for v in lo_hi], "out_range": list(span),
                        "curve": entry.get("curve", "linear")}, entry, line)
    for source, _, device in (axis, hold) if hold is not None else (axis,):
        if source not in blocks:
            _add(blocks, source, {"type": "haptic", "device": device}, entry, line)
    _connect(connect, f"{axis[0]}.{axis[1]} -> {name}.in", line)
    if hold is None:
        _connect(connect, f"{name}.out -> {block}.{param.name}", line)
        return
    held = _free(blocks, f"{name}_hold")
    _add(blocks, held, {"type": "sample_hold"}, entry, line)
    _connect(connect, f"{name}.out -> {held}.in", line)
    _connect(connect, f"{hold[0]}.{hold[1]} -> {held}.hold", line)
    _connect(connect, f"{held}.out -> {block}.{param.name}", line)


def _centred(port):
    base = port.rstrip("0123456789")
    return base in CENTRED or base.startswith("hat") and base.endswith(("_x", "_y"))


def _free(blocks, name):
    while name in blocks:
        name += "_"
    return name


def _connect(connect, text, line):
    connect.append(text)
    connect.lines.append(line)


def _device_port(entry, key, line, where, doc, registry, problems):
    """(haptic block name, port, device) of the entry's `axis` or `hold` (DEVICE.INPUT, or BLOCK.INPUT of
    a haptic block); the block is `map_DEVICE`, to be added, when the patch binds the device to
    none. None if wrong (reported)."""
    text, at = entry[key], entry.lines.get(key, line)
    first, _, port = text.partition(".")
    devices = doc.get("devices") if isinstance(doc.get("devices"), dict) else {}
    blocks = doc.get("blocks") if isinstance(doc.get("blocks"), dict) else {}
    bound = {spec.get("device"): b for b, spec in blocks.items()
             if isinstance(spec, dict) and spec.get("type") == "haptic" and isinstance(spec.get("device"), str)}
    if first in devices:
        device, block = first, bound.get(first, f"map_{first}")
    elif isinstance(blocks.get(first), dict) and blocks[first].get("type") == "haptic":
        device, block = blocks[first].get("device"), first
    else:
        problems.add(at, f"{where}: {key} {text!r}: no device named {first!r} under devices: "
                         f"(devices: {', '.join(devices) or 'none'})")
        return None
    spec = devices.get(device)
    kind = _kind(spec, registry.drivers) if isinstance(spec, dict) else None
    if kind is None:
        return None               # an unknown device or driver, reported with the device
    inputs = ["x", "v", *kind.axes(spec)]
    if port not in inputs:
        shown = ", ".join(inputs[:30]) + (", …" if len(inputs) > 30 else "")
        problems.add(at, f"{where}: {key} {text!r}: device {device!r} has no input {port!r} (its inputs: {shown})")
        return None
    return block, port, device


def _add(blocks, name, values, entry, line):
    spec = LDict(values)
    spec.line = line
    spec.lines = {k: entry.lines.get(k, line) for k in values}
    blocks[name] = spec
    blocks.lines[name] = line


__all__ = ["ITEM", "check_controls", "expand", "map_schema"]
