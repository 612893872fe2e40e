"""Loading a patch: YAML with lines → plugins → JSON Schema → block checks → wiring → schedule.

Every problem found is collected and raised together as one PatchError, so `hapticgraph check`
reports all of them at once.
"""
import difflib
import os
import re

import jsonschema

from .errors import Collector, PatchError
from .mapping import check_controls, expand as expand_map
from .network import check_cells, check_springs, check_stability, kernel_items
from .registry import Registry, RegistryError, driver_table
from .schedule import schedule
from .schema import INDEX, patch_schema
from .source import LDict, LList, line_of, load_yaml, parse_value

DEFAULT_RATE = 44100.0
# the most blocks one kernel holds (a fused mass-spring network counts as one): numba's memory
# grows with the kernel's size (docs/limits.md has the measurements)
MAX_BLOCKS = 1000
_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
_ENDPOINT = re.compile(rf"\s*({_NAME})(?:\[([^\]]*)\])?\.({_NAME})\s*")
_INDEX = re.compile(INDEX)     # the schema's: `[i, j]` of whole numbers


class Endpoint:
    """`block.port` or `block[i, j].port` in a connection."""

    __slots__ = ("block", "index", "port")

    def __init__(self, block, index, port):
        self.block, self.index, self.port = block, index, port

    def __str__(self):
        idx = "" if self.index is None else "[" + ", ".join(map(str, self.index)) + "]"
        return f"{self.block}{idx}.{self.port}"

    @classmethod
    def parse(cls, text):
        """An Endpoint, or None if `text` cannot be read (`problem` says why)."""
        m = _ENDPOINT.fullmatch(text)
        if not m or (m.group(2) is not None and not _INDEX.fullmatch(f"[{m.group(2)}]")):
            return None
        index = None if m.group(2) is None else tuple(int(v) for v in m.group(2).split(","))
        return cls(m.group(1), index, m.group(3))

    @staticmethod
    def problem(text):
        """Why `text` is not an endpoint: a sentence, or None if it is one."""
        m = _ENDPOINT.fullmatch(text)
        if m is None:
            return "write block.port, or name[i, j].port for a cell"
        if m.group(2) is not None and not _INDEX.fullmatch(f"[{m.group(2)}]"):
            return (f"the cell index [{m.group(2)}] must be whole numbers separated by commas, "
                    f"e.g. {m.group(1)}[1, 2].{m.group(3)}")
        return None


class Connection:
    __slots__ = ("src", "dst", "line")

    def __init__(self, src, dst, line):
        self.src, self.dst, self.line = src, dst, line

    def __str__(self):
        return f"{self.src} -> {self.dst}"


class Instance:
    """One block of a patch: its type, parameter values (defaults filled in) and ports."""

    def __init__(self, name, cls, values, line, lines, index):
        self.name, self.cls, self.values, self.line, self.lines, self.index = (
            name, cls, values, line, lines, index)
        self.inputs, self.outputs = cls.ports(values)

    @property
    def params(self):
        return self.cls.param_tuple()(**self.values)

    def input(self, name):
        """The In port (or live parameter name) called `name`, or None."""
        for port in self.inputs:
            if port.name == name:
                return port
        param = self.cls.params.get(name)
        return param if param is not None and param.live else None

    def output(self, name):
        for port in self.outputs:
            if port.name == name:
                return port
        return None

    def line_of(self, key):
        return self.lines.get(key, self.line)


class Patch:
    """A checked patch: blocks, connections, devices and the schedule (block names, in order)."""

    def __init__(self, file, doc, name, rate, blocks, connections, devices, order, registry):
        self.file, self.doc, self.name, self.rate = file, doc, name, rate
        self.blocks, self.connections, self.devices = blocks, connections, devices
        self.order, self.registry = order, registry

    def __repr__(self):
        return f"<Patch {self.name!r} from {self.file}: {len(self.blocks)} blocks at {self.rate:g} Hz>"


def load(path, overrides=(), registry=None, drivers=None):
    """Load and check a patch file; raise PatchError listing every problem found.

    `drivers` (driver kinds, see hapticgraph.graph.registry) replaces the registry's: the device
    drivers the patch's `devices:` entries may name."""
    path = os.fspath(path)
    doc, problems = load_yaml(path)
    if doc is None:
        problems.raise_if_any()
    if not isinstance(doc, LDict):
        problems.add(getattr(doc, "line", 1), "a patch is a mapping with keys hapticgraph: 1, blocks: and connect:")
        problems.raise_if_any()
    if doc.get("hapticgraph") != 1:
        where = doc.lines.get("hapticgraph", 1)
        problems.add(where, "the first key must be `hapticgraph: 1` (the patch format version)"
                     if "hapticgraph" not in doc else
                     f"unsupported patch format version {doc['hapticgraph']!r}; this hapticgraph reads version 1")
        problems.raise_if_any()

    if registry is None:
        registry = Registry(drivers=drivers)
    elif drivers is not None:
        registry.drivers = driver_table(drivers)
    _load_plugins(doc, registry, os.path.dirname(os.path.abspath(path)), problems)
    _apply_overrides(doc, overrides, registry, problems)
    _stop_if_full(problems)
    _check_schema(doc, registry, problems)
    _stop_if_full(problems)
    _check_drivers(doc.get("devices"), registry.drivers, os.path.dirname(os.path.abspath(path)), problems)
    check_controls(doc, registry, problems)
    doc = expand_map(doc, registry, problems)     # `map:` entries become blocks and connections
    raw_rate = doc.get("rate", DEFAULT_RATE)
    valid_rate = isinstance(raw_rate, (int, float)) and not isinstance(raw_rate, bool) and 100 <= raw_rate <= 1e6
    rate = float(raw_rate) if valid_rate else DEFAULT_RATE   # a bad rate is reported by the schema
    blocks = _instances(doc, registry, rate, problems)
    _stop_if_full(problems)
    connections = _connections(doc, blocks, problems)
    _stop_if_full(problems)
    before = len(problems.problems)
    declared = set(doc["blocks"]) if isinstance(doc.get("blocks"), LDict) else set()
    check_springs(blocks, problems, declared)
    check_cells(blocks, problems)     # before anything sized by the cells is built
    if len(problems.problems) == before:
        check_stability(blocks, rate, problems)
    audio = [b for b in blocks.values() if getattr(b.cls, "audio_sink", False)]
    for extra in audio[1:]:
        problems.add(extra.line, f"block {extra.name!r}: a patch has at most one audio_out "
                                 f"(the first is {audio[0].name!r})")
    devices = doc.get("devices") if isinstance(doc.get("devices"), LDict) else LDict()
    _check_devices(devices, blocks, problems)
    _stop_if_full(problems)
    items = kernel_items(blocks)
    if items > MAX_BLOCKS:
        problems.add(doc.lines.get("blocks", 1),
                     f"the patch has {items:,} blocks to compile (a mass-spring network counts as one); "
                     f"one kernel holds at most {MAX_BLOCKS:,}: compiling more takes more memory than "
                     "hapticgraph allows (docs/limits.md)")
        problems.raise_if_any()
    order = schedule(blocks, connections, problems)
    problems.raise_if_any()
    name = doc.get("name") or os.path.splitext(os.path.basename(path))[0]
    return Patch(path, doc, name, rate, blocks, connections, devices, order, registry)


def _stop_if_full(problems):
    """Past the problem limit nothing more is checked: report what was found."""
    if problems.full:
        problems.raise_if_any()


_MODULE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*")


def _load_plugins(doc, registry, base, problems):
    """`plugins:` entries are module names or .py files; anything else is reported (a wrong type
    or an empty name by the schema) and never handed to the importer."""
    plugins = doc.get("plugins")
    if not isinstance(plugins, LList):
        return
    for spec, line in zip(plugins, plugins.lines):
        if not isinstance(spec, str) or not spec:
            continue   # reported by the schema
        if not (spec.endswith(".py") or "/" in spec or os.sep in spec or _MODULE.fullmatch(spec)):
            problems.add(line, f"plugins: {spec!r} is neither a module name (my_blocks, pkg.blocks) "
                               "nor a .py file")
            continue
        try:
            registry.load_plugin(spec, base)
        except RegistryError as exc:
            problems.add(line, str(exc))


def _names(names, most=20):
    names = list(names)
    shown = ", ".join(names[:most])
    return shown + (f", … ({len(names) - most} more)" if len(names) > most else "") if names else "none"


def _apply_overrides(doc, overrides, registry, problems):
    """`--set BLOCK.PARAM=VALUE`: the value is read by the loader's guarded path (budgets, no
    tags, finite numbers) and then checked by the schema like the file's own values."""
    blocks = doc.get("blocks")
    for text in overrides:
        target, sep, raw = text.partition("=")
        block, dot, param = target.strip().partition(".")
        if not sep or not dot or not block or not param:
            problems.add(1, f"--set {text!r}: expected BLOCK.PARAM=VALUE")
            continue
        if not isinstance(blocks, LDict) or not isinstance(blocks.get(block), LDict):
            have = list(blocks) if isinstance(blocks, LDict) else []
            problems.add(1, f"--set {text!r}: the patch has no block named {block!r}{_suggest(block, have)}; "
                            f"its blocks: {_names(have)}")
            continue
        entry = blocks[block]
        line = blocks.lines.get(block, entry.line)
        cls = registry.types.get(entry.get("type"))
        if cls is not None and param != "type":
            public = [n for n, p in cls.params.items() if not p.internal]
            if param not in public:
                problems.add(line, f"--set {text!r}: block {block!r} ({cls.type_name}) has no parameter "
                                   f"{param!r}{_suggest(param, public)}; its parameters: {_names(public)}")
                continue
        inner = Collector(problems.file)
        ok, value = parse_value(raw, inner, line)
        for p in inner.problems:
            problems.add(line, f"--set {text!r}: {p.message}")
        if ok:
            entry[param] = value
            entry.lines[param] = line


def _suggest(word, choices):
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_schema(doc, registry, problems):
    blocks = doc.get("blocks")
    skip_blocks = set()
    if isinstance(blocks, LDict):
        for name, spec in blocks.items():
            if problems.full:
                return
            line = blocks.lines[name]
            if not isinstance(spec, LDict):
                continue
            kind = spec.get("type")
            if kind is None:
                problems.add(line, f"block {name!r}: no `type` (one of: {', '.join(sorted(registry.types))})")
                skip_blocks.add(name)
            elif kind not in registry.types:
                problems.add(spec.lines.get("type", line),
                             f"block {name!r}: unknown type {kind!r}{_suggest(str(kind), registry.types)}")
                skip_blocks.add(name)
            else:
                cls = registry.types[kind]
                for key in spec:
                    if key != "type" and (key not in cls.params or cls.params[key].internal):
                        public = [n for n, p in cls.params.items() if not p.internal]
                        problems.add(spec.lines[key],
                                     f"block {name!r} ({kind}): unknown parameter {key!r}"
                                     f"{_suggest(key, public)}")
    validator = jsonschema.Draft202012Validator(patch_schema(registry))
    for err in validator.iter_errors(doc):
        if problems.full:
            return
        path = list(err.absolute_path)
        if len(path) >= 2 and path[0] == "blocks" and path[1] in skip_blocks:
            continue
        if err.validator == "additionalProperties" and len(path) == 2 and path[0] == "blocks":
            continue  # unknown parameters, reported above with a suggestion
        if err.validator in ("if", "allOf"):
            continue
        if len(path) == 3 and path[0] == "devices" and path[2] == "driver":
            continue  # an unknown driver, reported by _check_drivers with a suggestion
        problems.add(line_of(doc, path), _describe(err, path, doc, registry))


def _describe(err, path, doc, registry):
    what, unit = "patch", ""
    if path and path[0] == "blocks" and len(path) >= 2:
        spec = doc["blocks"].get(path[1])
        kind = spec.get("type") if isinstance(spec, dict) else None
        what = f"block {path[1]!r}" + (f" ({kind})" if kind else "")
        if len(path) >= 3:
            what += f": parameter {path[2]!r}"
            rest = "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in path[3:])
            if rest:
                what += f" {rest.lstrip('.')}"
            cls = registry.types.get(kind)
            unit = cls.params[path[2]].unit if cls and path[2] in cls.params else ""
    elif path and path[0] == "connect":
        what = f"connection {err.instance!r}" if isinstance(err.instance, str) else "connect"
    elif path:
        what = ".".join(str(p) for p in path)
    v, s = err.instance, err.validator_value
    unit = f" {unit}" if unit else ""
    messages = {
        "minimum": lambda: f"{v!r} is below the minimum {s!r}{unit}",
        "maximum": lambda: f"{v!r} is above the maximum {s!r}{unit}",
        "exclusiveMinimum": lambda: f"{v!r} must be greater than {s!r}{unit}",
        "exclusiveMaximum": lambda: f"{v!r} must be less than {s!r}{unit}",
        "type": lambda: f"{v!r} is not {'an' if s[0] in 'aeiou' else 'a'} {s}",
        "enum": lambda: f"{v!r} is not one of {', '.join(map(repr, s))}",
        "const": lambda: f"{v!r} must be {s!r}",
        "minItems": lambda: f"needs at least {s} item(s), has {len(v)}",
        "maxItems": lambda: f"takes at most {s} item(s), has {len(v)}",
        "pattern": lambda: (_connection_problem(v) if path and path[0] == "connect"
                            else f"{v!r} is not a valid name"),
        "required": lambda: f"missing {', '.join(repr(r) for r in s if r not in v)}",
        "additionalProperties": lambda: f"unknown key(s) {', '.join(repr(k) for k in v if k not in err.schema.get('properties', {}))}",
        "minLength": lambda: "must not be empty",
    }
    make = messages.get(err.validator)
    text = make() if make else err.message
    if err.validator == "pattern" and path and path[0] == "connect":
        return text
    return f"{what}: {text}"


def _connection_problem(text):
    left, arrow, right = text.partition("->")
    if arrow:
        for side in (left, right):
            reason = Endpoint.problem(side)
            if reason and "cell index" in reason:
                return f"cannot read {text.strip()!r}: {reason}"
    return f"cannot read {text!r}: write \"block.port -> block.port\""


def _instances(doc, registry, rate, problems):
    blocks = doc.get("blocks")
    out = {}
    if not isinstance(blocks, LDict):
        return out
    for index, (name, spec) in enumerate(blocks.items()):
        if problems.full:
            break
        if not isinstance(spec, LDict) or spec.get("type") not in registry.types:
            continue
        cls = registry.types[spec["type"]]
        values = cls.default_params()
        ok = True
        for key, param in cls.params.items():
            if key in spec:
                value = spec[key]
                if not _valid(param, value):
                    ok = False
                    continue
                values[key] = param.value_of(value)
        if not ok:
            continue
        for pname, param in cls.params.items():
            if param.refers == "devices" and "axes" in cls.params:
                values["axes"] = device_axes(doc.get("devices"), values[pname], registry.drivers)
        inst = Instance(name, cls, values, blocks.lines[name], spec.lines, index)
        for pname, param in cls.params.items():
            if param.refers == "file" and values[pname]:
                path = os.path.join(os.path.dirname(os.path.abspath(problems.file)), values[pname])
                if not os.path.isfile(path):
                    problems.add(inst.line_of(pname), f"block {name!r} ({cls.type_name}): parameter {pname!r}: "
                                                      f"no file {values[pname]!r} beside the patch")
        before = len(problems.problems)
        try:
            for param, message in cls.check(inst.params, rate):
                problems.add(inst.line_of(param) if param else inst.line,
                             f"block {name!r} ({cls.type_name})" + (f": parameter {param!r}" if param else "")
                             + f": {message}")
        except Exception as exc:  # noqa: BLE001 - a plugin's check must not crash the loader
            problems.add(inst.line, f"block {name!r} ({cls.type_name}): its check failed: {exc!r}")
        if len(problems.problems) == before:
            out[name] = inst   # a block with problems takes no further part (wiring, networks)
    return out


def driver_of(spec, drivers):
    """The driver kind of a device entry: its `driver:`, else the default kind; None if unknown."""
    name = spec.get("driver") if isinstance(spec, dict) else None
    if name is None:
        return next((k for k in drivers.values() if k.default), None)
    return drivers.get(name) if isinstance(name, str) else None


def device_axes(devices, name, drivers):
    """A device's extra axes and buttons, as its driver kind reads them from its entry."""
    spec = devices.get(name) if isinstance(devices, dict) else None
    kind = driver_of(spec, drivers) if isinstance(spec, dict) else None
    return list(kind.axes(spec)) if kind is not None else []


def _check_drivers(devices, drivers, base, problems):
    """Each device entry names a known driver (or there is a default one), which checks the rest."""
    if not isinstance(devices, LDict):
        return
    for name, spec in devices.items():
        if not isinstance(spec, LDict):
            continue
        kind = driver_of(spec, drivers)
        if kind is None:
            given = spec.get("driver")
            known = ", ".join(sorted(drivers)) or "none (the loader was given no driver table)"
            what = (f"unknown driver {given!r}{_suggest(str(given), drivers)}" if given is not None
                    else "no driver given, and there is no default one")
            problems.add(spec.lines.get("driver", spec.line), f"device {name!r}: {what}; the drivers are: {known}")
            continue
        kind.check(name, spec, base, problems)


def _check_devices(devices, blocks, problems):
    """Every device reference names a declared device, once."""
    users = {}
    for inst in blocks.values():
        for pname, param in inst.cls.params.items():
            if param.refers != "devices":
                continue
            value = inst.values[pname]
            line = inst.line_of(pname)
            if not value:
                problems.add(line, f"block {inst.name!r} ({inst.cls.type_name}): parameter {pname!r}: "
                                   f"name the device (one of: {', '.join(devices) or 'none declared under devices:'})")
            elif value not in devices:
                problems.add(line, f"block {inst.name!r} ({inst.cls.type_name}): parameter {pname!r}: "
                                   f"no device named {value!r} under devices:{_suggest(value, devices)}")
            elif value in users:
                problems.add(line, f"block {inst.name!r}: device {value!r} is already bound to block {users[value]!r}")
            else:
                users[value] = inst.name


def _valid(param, value):
    try:
        jsonschema.validate(value, param.schema())
        return True
    except jsonschema.ValidationError:
        return False


def _connections(doc, blocks, problems):
    conns = doc.get("connect")
    out = []
    if not isinstance(conns, LList):
        return out
    names = doc.get("blocks") if isinstance(doc.get("blocks"), LDict) else {}
    for text, line in zip(conns, conns.lines):
        if problems.full:
            break
        if not isinstance(text, str) or "->" not in text:
            continue  # reported by the schema
        left, _, right = text.partition("->")
        src, dst = Endpoint.parse(left), Endpoint.parse(right)
        if src is None or dst is None:
            continue  # reported by the schema (its pattern), with the reason
        ok = True
        for end, role in ((src, "output"), (dst, "input")):
            if end.block not in names:
                problems.add(line, f"connection {text.strip()!r}: no block named {end.block!r}"
                                   f"{_suggest(end.block, names)}")
                ok = False
                continue
            inst = blocks.get(end.block)
            if inst is None:
                ok = False  # the block itself has a problem, reported already
                continue
            if not _check_endpoint(inst, end, role, text.strip(), line, problems):
                ok = False
        if ok:
            out.append(Connection(src, dst, line))
    return out


def _check_endpoint(inst, end, role, text, line, problems):
    cls = inst.cls
    if end.index is not None:
        check_cell = getattr(cls, "check_cell", None)
        if check_cell is None:
            problems.add(line, f"connection {text!r}: block {inst.name!r} ({cls.type_name}) has no cells "
                               f"to index with [{', '.join(map(str, end.index))}]")
            return False
        message = check_cell(inst.values, end.index, end.port, role)
        if message:
            problems.add(line, f"connection {text!r}: {inst.name}[{', '.join(map(str, end.index))}]: {message}")
            return False
        return True
    found = inst.output(end.port) if role == "output" else inst.input(end.port)
    if found is not None:
        return True
    if getattr(cls, "check_cell", None) is not None and end.port in ("position", "velocity", "force"):
        problems.add(line, f"connection {text!r}: {inst.name!r} is a {cls.type_name}; address one of its cells "
                           f"as {inst.name}[i, ...].{end.port}")
        return False
    other = inst.input(end.port) if role == "output" else inst.output(end.port)
    ports = [p.name for p in (inst.outputs if role == "output" else inst.inputs)]
    if role == "input":
        ports += [n for n, p in cls.params.items() if p.live]
    if other is not None:
        msg = f"{end.port!r} of block {inst.name!r} ({cls.type_name}) is an {'input' if role == 'output' else 'output'}, " \
              f"it cannot be the {'source' if role == 'output' else 'destination'} of a connection"
    elif role == "input" and end.port in cls.params:
        msg = f"parameter {end.port!r} of block {inst.name!r} ({cls.type_name}) is not live, so it is not an input"
    else:
        msg = (f"block {inst.name!r} ({cls.type_name}) has no {role} {end.port!r}"
               f"{_suggest(end.port, ports)}; its {role}s: {', '.join(ports) or 'none'}")
    problems.add(line, f"connection {text!r}: {msg}")
    return False


__all__ = ["load", "Patch", "Instance", "Connection", "Endpoint", "PatchError", "Collector"]
