"""The studio's edits as changes of the patch text: each takes the text and the patch it loads
to, and returns the new text (which the studio then loads again before anything changes).

Cells are written as in probes: `s[3]`, `plate[4, 5]`; a `cell` block by its name.
"""
import re

from ruamel.yaml.nodes import MappingNode, ScalarNode, SequenceNode

from ..graph.patch import Endpoint
from . import yamltext as yt

_CELL = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[\s*(-?\d+(?:\s*,\s*-?\d+)*)\s*\])?\s*")


class EditError(ValueError):
    """An edit that cannot be written (the message says why); nothing changed."""


def parse_cell(text):
    """(block, index tuple or None) of a cell written as in probes."""
    m = _CELL.fullmatch(text) if isinstance(text, str) else None
    if m is None:
        raise EditError(f"{text!r} is not a cell: write lattice[i, j] (or a cell block's name)")
    index = None if m.group(2) is None else tuple(int(v) for v in m.group(2).split(","))
    return m.group(1), index


def cell_text(block, index):
    return block if index is None else f"{block}[{', '.join(str(i) for i in index)}]"


def plain(node):
    """A composed node as plain Python (ints, floats, strings, lists, dicts)."""
    if isinstance(node, SequenceNode):
        return [plain(v) for v in node.value]
    if isinstance(node, MappingNode):
        return {plain(k): plain(v) for k, v in node.value}
    if isinstance(node, ScalarNode):
        for conv in (int, float):
            try:
                return conv(node.value)
            except ValueError:
                pass
        return node.value
    return None


def _block(patch, name, types=None):
    inst = patch.blocks.get(name)
    if inst is None:
        raise EditError(f"no block named {name!r}")
    if types is not None and inst.cls.type_name not in types:
        raise EditError(f"block {name!r} is a {inst.cls.type_name}, not a {' or '.join(types)}")
    return inst


def set_param(text, patch, block, param, value):
    inst = _block(patch, block)
    if param not in inst.cls.params or param == "type":
        raise EditError(f"block {block!r} ({inst.cls.type_name}) has no parameter {param!r}")
    return yt.set_key(text, ("blocks", block), param, yt.format_value(value))


def _index_items(text, block, key):
    """[(item number, index list)] of the lattice's `lock:` or `cut:` list."""
    nodes, _ = yt.items(yt.compose(text), ("blocks", block, key))
    return [(i, plain(n)) for i, n in enumerate(nodes)]


def cell_edit(text, patch, action, cell):
    """lock, unlock or cut one cell."""
    block, index = parse_cell(cell)
    inst = _block(patch, block, ("lattice", "cell"))
    if inst.cls.type_name == "cell":
        if index is not None:
            raise EditError(f"{block!r} is a cell block: write it without an index")
        if action == "cut":
            raise EditError(f"{block!r} is a cell block: remove it instead of cutting it")
        return yt.set_key(text, ("blocks", block), "locked", "true" if action == "lock" else "false")
    if index is None:
        raise EditError(f"{block!r} is a lattice: name one of its cells, e.g. {block}[0]")
    key = "cut" if action == "cut" else "lock"
    present = [i for i, v in _index_items(text, block, key) if v == list(index)]
    if action in ("lock", "cut"):
        return text if present else yt.append_item(text, ("blocks", block, key), yt.format_value(list(index)))
    for i in reversed(present):
        text = _drop_item(text, ("blocks", block, "lock"), i)
    overrides = _override_items(text, block)
    for i, item in overrides:
        if item.get("index") == list(index) and item.get("locked"):
            text = yt.remove_key(text, ("blocks", block, "cells", i), "locked")
            present.append(i)
    if not present:
        raise EditError(f"{cell_text(block, index)} is not locked")
    return text


def _drop_item(text, path, i):
    """Item i removed from the list at `path`; the key too when it was the last item, so that
    an edit and its reverse give back the text as it was."""
    nodes, _ = yt.items(yt.compose(text), path)
    if len(nodes) == 1:
        return yt.remove_key(text, path[:-1], path[-1])
    return yt.remove_item(text, path, i)


def _override_items(text, block):
    nodes, _ = yt.items(yt.compose(text), ("blocks", block, "cells"))
    return [(i, plain(n)) for i, n in enumerate(nodes)]


def cells(text, patch, block, indices, values):
    """Per-cell overrides (`cells:` of a lattice): values {"mass"|"damping": number or None}."""
    _block(patch, block, ("lattice",))
    for key in values:
        if key not in ("mass", "damping"):
            raise EditError(f"cells: {key!r} is not a per-cell value (mass, damping)")
    for index in indices:
        index = [int(i) for i in index]
        found = [i for i, item in _override_items(text, block) if item.get("index") == index]
        if found:
            path = ("blocks", block, "cells", found[0])
            for key, value in values.items():
                text = (yt.remove_key(text, path, key) if value is None
                        else yt.set_key(text, path, key, yt.format_value(float(value))))
            left = dict(_override_items(text, block))[found[0]]
            if set(left) == {"index"}:
                text = _drop_item(text, ("blocks", block, "cells"), found[0])
        else:
            item = {"index": index, **{k: float(v) for k, v in values.items() if v is not None}}
            if len(item) > 1:
                text = yt.append_item(text, ("blocks", block, "cells"), yt.format_value(item))
    return text


def add_block(text, name, spec):
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name or "") is None:
        raise EditError(f"{name!r} is not a block name (letters, digits, _)")
    if yt.find(yt.compose(text), ("blocks", name)) is not None:
        raise EditError(f"there is already a block named {name!r}")
    return yt.set_key(text, ("blocks",), name, yt.format_value(spec))


def join(text, patch, a, b, tension=None, name=None):
    """A spring block joining two cells."""
    ends = []
    for cell in (a, b):
        block, index = parse_cell(cell)
        _block(patch, block, ("lattice", "cell"))
        ends.append(_block(patch, block))
    if tension is None:
        tensions = [e.values.get("tension", 0.0) for e in ends if e.cls.type_name == "lattice"]
        tension = sum(tensions) / len(tensions) if tensions else 100.0
    if name is None:
        n = 1
        while f"join{n}" in patch.blocks:
            n += 1
        name = f"join{n}"
    spec = {"type": "spring", "a": cell_text(*parse_cell(a)), "b": cell_text(*parse_cell(b)),
            "tension": float(tension)}
    return add_block(text, name, spec), name


def _connections(text):
    """[(item number, src Endpoint, dst Endpoint, node)] of the `connect:` list; in flow style?"""
    nodes, flow = yt.items(yt.compose(text), ("connect",))
    out = []
    for i, node in enumerate(nodes):
        if isinstance(node, ScalarNode) and "->" in node.value:
            left, _, right = node.value.partition("->")
            src, dst = Endpoint.parse(left), Endpoint.parse(right)
            if src is not None and dst is not None:
                out.append((i, src, dst, node))
    return out, flow


def _set_connection(text, i, node, flow, src, dst):
    new = yt.scalar_text(node, f"{src} -> {dst}", flow)
    return yt.replace_node(text, yt.items(yt.compose(text), ("connect",))[0][i], new)


def add_connection(text, src, dst):
    nodes, flow = yt.items(yt.compose(text), ("connect",))
    return yt.append_item(text, ("connect",), yt.scalar_text(nodes[0] if nodes else None, f"{src} -> {dst}", flow))


def _body(patch, cell):
    block, index = parse_cell(cell)
    _block(patch, block, ("lattice", "cell"))
    return block, index


def _is_body(patch, name):
    inst = patch.blocks.get(name)
    return inst is not None and inst.cls.type_name in ("lattice", "cell")


def place(text, patch, block, cell, port=None, type=None, params=None):
    """Move a microphone (the cell feeding its `in`) or an excitation (the cell its output
    drives) onto `cell`; with `type`, a new one is added and wired. Returns the new text."""
    cb, index = _body(patch, cell)
    if block not in patch.blocks:
        if not type:
            raise EditError(f"no block named {block!r} (give `type` to add a new microphone or excitation)")
        return _add_placed(text, patch, block, type, cb, index, port, params or {})
    if type is not None and type != patch.blocks[block].cls.type_name:
        raise EditError(f"block {block!r} is a {patch.blocks[block].cls.type_name}, not a {type}")
    conns, flow = _connections(text)
    if patch.blocks[block].cls.type_name == "mic":
        for i, src, dst, node in conns:
            if dst.block == block and dst.port == "in" and _is_body(patch, src.block):
                return _set_connection(text, i, node, flow, Endpoint(cb, index, port or src.port), dst)
        return add_connection(text, Endpoint(cb, index, port or "velocity"), f"{block}.in")
    for i, src, dst, node in conns:
        if src.block == block and dst.port == "force" and _is_body(patch, dst.block):
            return _set_connection(text, i, node, flow, src, Endpoint(cb, index, "force"))
    outs = [p.name for p in patch.blocks[block].outputs]
    if not outs:
        raise EditError(f"block {block!r} ({patch.blocks[block].cls.type_name}) has no output to drive a cell")
    return add_connection(text, f"{block}.{'out' if 'out' in outs else outs[0]}", Endpoint(cb, index, "force"))


def _add_placed(text, patch, block, type, cb, index, port, params):
    if not isinstance(params, dict):
        raise EditError("place: `params` is a mapping of parameter values")
    text = add_block(text, block, {"type": type, **params})
    if type != "mic":
        return add_connection(text, f"{block}.out", Endpoint(cb, index, "force"))
    text = add_connection(text, Endpoint(cb, index, port or "velocity"), f"{block}.in")
    sinks = [b for b in patch.blocks.values() if getattr(b.cls, "audio_sink", False)]
    if sinks:
        names = [p.name for p in sinks[0].inputs]
        pairs = (("left", "left"), ("right", "right")) if "left" in names else (("left", names[0]),)
        for mine, theirs in pairs:
            text = add_connection(text, f"{block}.{mine}", f"{sinks[0].name}.{theirs}")
    return text


def remove(text, patch, block):
    """The block and every connection to or from it."""
    _block(patch, block)
    conns, _ = _connections(text)
    for i, src, dst, _node in reversed(conns):
        if block in (src.block, dst.block):
            text = yt.remove_item(text, ("connect",), i)
    return yt.remove_key(text, ("blocks",), block)


def write_map(text, entries):
    """The patch's `map:` section written as `entries` (a list of mappings); [] removes it."""
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise EditError("map: `entries` is a list of mappings such as {\"param\": \"blk.tension\", \"cc\": 74}")
    root = yt.compose(text)
    if not entries:
        return yt.remove_key(text, (), "map")
    old = yt.find(root, ("map",))
    if old is not None:
        if isinstance(old, SequenceNode) and not old.flow_style and old.value:
            column = old.start_mark.column
            return yt.replace_node(text, old, yt.block_list(entries, column).lstrip("\n").lstrip(" "))
        return yt.replace_node(text, old, yt.format_value(entries))
    column = 2
    return yt.set_key(text, (), "map", yt.block_list(entries, column))
