"""Loading a patch: YAML with lines → plugins → JSON Schema → block checks → wiring → schedule.

Every problem found is collected and raised together as one PatchError, so `hapticgraph check`
reports all of them at once.
"""
import os
import re

from .entries import check_bound_blocks, check_drivers, device_axes, driver_of  # noqa: F401  (devices/ reads these here)
from .errors import Collector, PatchError, name_list, suggest
from .family import check_families, kernel_cost
from .model import Connection, Endpoint, Instance, Patch
from .registry import Registry, RegistryError, driver_table
from .schedule import schedule
from .source import LDict, LList, load_yaml, parse_value
from .validate import check_schema
from .voices import expand as expand_voices
from .wiring import connections_of

DEFAULT_RATE = 44100.0
# the most blocks one kernel holds (a fused mass-spring network counts as one): numba's memory
# grows with the kernel's size (docs/limits.md has the measurements)
MAX_BLOCKS = 1000


def load(path, overrides=(), registry=None, drivers=None, text=None):
    """Load and check a patch file; raise PatchError listing every problem found.

    `drivers` (driver kinds, see hapticgraph.graph.registry) replaces the registry's: the device
    drivers the patch's `devices:` entries may name. `text`, when given, is the patch's text,
    read instead of the file (an edit not yet saved; plugins and problems still relative to `path`)."""
    path = os.fspath(path)
    doc, problems = _read_document(path, text)
    if registry is None:
        registry = Registry(drivers=drivers)
    elif drivers is not None:
        registry.drivers = driver_table(drivers)
    _load_plugins(doc, registry, os.path.dirname(os.path.abspath(path)), problems)
    doc = expand_voices(doc, registry, problems)     # a `voices:` template becomes blocks per voice
    _apply_overrides(doc, overrides, registry, problems)
    _stop_if_full(problems)
    checked = _checked_specs(doc) if check_schema(doc, registry, problems) else {}
    _stop_if_full(problems)
    check_drivers(doc.get("devices"), registry.drivers, os.path.dirname(os.path.abspath(path)), problems)
    doc = _prepare(doc, registry, problems)     # e.g. `map:` entries become blocks and connections
    raw_rate = doc.get("rate", DEFAULT_RATE)
    valid_rate = isinstance(raw_rate, (int, float)) and not isinstance(raw_rate, bool) and 100 <= raw_rate <= 1e6
    rate = float(raw_rate) if valid_rate else DEFAULT_RATE   # a bad rate is reported by the schema
    blocks = _instances(doc, registry, rate, problems, checked)
    _stop_if_full(problems)
    connections = connections_of(doc, blocks, problems)
    _stop_if_full(problems)
    devices = _check_whole(doc, blocks, rate, problems)
    order = schedule(blocks, connections, problems)
    problems.raise_if_any()
    name = doc.get("name") or os.path.splitext(os.path.basename(path))[0]
    return Patch(path, doc, name, rate, blocks, connections, devices, order, registry)


def _prepare(doc, registry, problems):
    """The document after each driver kind's `prepare` (optional: checks and shorthands of its
    own sections, such as the controllers' `map:`), each distinct one once."""
    done = set()
    for kind in registry.drivers.values():
        prepare = getattr(kind, "prepare", None)
        key = getattr(prepare, "__func__", prepare)
        if prepare is not None and key not in done:
            done.add(key)
            doc = prepare(doc, registry, problems)
    return doc


def _read_document(path, text=None):
    """The patch's YAML document (an LDict) and its problem collector; PatchError unless it is a
    mapping of format version 1."""
    doc, problems = load_yaml(path, text)
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
    return doc, problems


def _check_whole(doc, blocks, rate, problems):
    """What needs every block at once: the families' checks, one audio sink, the devices, the size
    of the kernel. The devices section (an LDict)."""
    declared = set(doc["blocks"]) if isinstance(doc.get("blocks"), LDict) else set()
    check_families(blocks, problems, declared, rate)
    audio = [b for b in blocks.values() if getattr(b.cls, "audio_sink", False)]
    for extra in audio[1:]:
        problems.add(extra.line, f"block {extra.name!r}: a patch has at most one audio_out "
                                 f"(the first is {audio[0].name!r})")
    devices = doc.get("devices") if isinstance(doc.get("devices"), LDict) else LDict()
    check_bound_blocks(devices, blocks, problems)
    _stop_if_full(problems)
    items = kernel_cost(blocks)
    if items > MAX_BLOCKS:
        problems.add(doc.lines.get("blocks", 1),
                     f"the patch has {items:,} blocks to compile (a fused group counts as one); "
                     f"one kernel holds at most {MAX_BLOCKS:,}: compiling more takes more memory than "
                     "hapticgraph allows (docs/limits.md)")
        problems.raise_if_any()
    return devices


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


def _apply_overrides(doc, overrides, registry, problems):
    """`--set BLOCK.PARAM=VALUE`: the value is read by the loader's guarded path (budgets, no
    tags, finite numbers) and then checked by the schema like the file's own values."""
    blocks = doc.get("blocks")
    for text in overrides:
        target, sep, raw = text.partition("=")
        block, dot, param = target.strip().partition(".")
        if not sep or not dot or not block or not param:
            problems.add(*_bare_set(text, block, blocks, registry))
            continue
        if not isinstance(blocks, LDict) or not isinstance(blocks.get(block), LDict):
            have = list(blocks) if isinstance(blocks, LDict) else []
            problems.add(1, f"--set {text!r}: the patch has no block named {block!r}{suggest(block, have)}; "
                            f"its blocks: {name_list(have)}")
            continue
        entry = blocks[block]
        line = blocks.lines.get(block, entry.line)
        cls = registry.lookup(entry.get("type"))
        if cls is not None and param != "type":
            public = [n for n, p in cls.params.items() if not p.internal]
            if param not in public:
                problems.add(line, f"--set {text!r}: block {block!r} ({cls.type_name}) has no parameter "
                                   f"{param!r}{suggest(param, public)}; its parameters: {name_list(public)}")
                continue
        inner = Collector(problems.file)
        ok, value = parse_value(raw, inner, line)
        for p in inner.problems:
            problems.add(line, f"--set {text!r}: {p.message}")
        if ok:
            entry[param] = value
            entry.lines[param] = line


def _bare_set(text, block, blocks, registry):
    """(line, message) of a --set that is not BLOCK.PARAM=VALUE: the block's parameters when it
    names a block without one, else the block names with a did-you-mean."""
    have = list(blocks) if isinstance(blocks, LDict) else []
    entry = blocks.get(block) if isinstance(blocks, LDict) else None
    cls = registry.lookup(entry.get("type")) if isinstance(entry, LDict) else None
    if cls is not None:
        public = [n for n, p in cls.params.items() if not p.internal]
        return (blocks.lines.get(block, entry.line),
                f"--set {text!r}: expected BLOCK.PARAM=VALUE; block {block!r} ({cls.type_name}) has the "
                f"parameters: {name_list(public)}")
    if block and block.isidentifier() and block not in have:
        return 1, (f"--set {text!r}: expected BLOCK.PARAM=VALUE; the patch has no block named "
                   f"{block!r}{suggest(block, have)}; its blocks: {name_list(have)}")
    return 1, f"--set {text!r}: expected BLOCK.PARAM=VALUE"


def _checked_specs(doc):
    """id -> (spec, its values) of each block spec of a document the schema found clean: a value
    still there (the same object) needs no second check (_valid)."""
    blocks = doc.get("blocks")
    items = blocks.values() if isinstance(blocks, dict) else ()
    return {id(spec): (spec, dict(spec)) for spec in items if isinstance(spec, dict)}


def _instances(doc, registry, rate, problems, checked):
    blocks = doc.get("blocks")
    out = {}
    if not isinstance(blocks, LDict):
        return out
    for index, (name, spec) in enumerate(blocks.items()):
        if problems.full:
            break
        cls = registry.lookup(spec.get("type")) if isinstance(spec, LDict) else None
        if cls is None:
            continue
        values = cls.default_params()
        ok = True
        seen = checked.get(id(spec), (None, {}))[1]
        for key, param in cls.params.items():
            if key in spec:
                value = spec[key]
                if not (seen.get(key, _valid) is value or _valid(param, value)):
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


def _valid(param, value):
    import jsonschema          # heavy: only for a value the whole document's check did not cover
    try:
        jsonschema.validate(value, param.schema())
        return True
    except jsonschema.ValidationError:
        return False


__all__ = ["load", "Patch", "Instance", "Connection", "Endpoint", "PatchError", "Collector"]
