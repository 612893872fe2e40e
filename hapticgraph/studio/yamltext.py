"""Edits of a patch's text that keep everything else byte for byte.

ruamel.yaml (round-trip mode) composes the text into nodes that know where they start and end
(`start_mark.index`, `end_mark.index`); an edit replaces, inserts or removes only the span of the
value it changes, in the style of its surroundings (a flow mapping gets `, key: value` before its
`}`, a block sequence a new `- item` line at its indentation). Comments, blank lines, key order
and number formatting elsewhere are never touched, because the rest of the text is never
re-emitted.
"""
import json
import math
import re

from ruamel.yaml import YAML
from ruamel.yaml.error import YAMLError
from ruamel.yaml.nodes import MappingNode, ScalarNode, SequenceNode

_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-/]*")
_RESERVED = frozenset(("true", "false", "null", "yes", "no", "on", "off", "y", "n", "~"))


class TextError(ValueError):
    """The text cannot be edited there (not YAML, or not the shape the edit expects)."""


def compose(text):
    """The root node of `text` (ruamel.yaml round-trip composer); TextError if it is not YAML."""
    try:
        node = YAML(typ="rt").compose(text)
    except YAMLError as exc:
        raise TextError(f"the patch text is not YAML: {exc}".splitlines()[0]) from None
    if not isinstance(node, MappingNode):
        raise TextError("the patch text is not a mapping")
    return node


def format_value(value):
    """YAML (flow style) text for a JSON-like value: numbers as Python writes them (shortest
    round trip), plain strings when they read back as the same string, else double-quoted."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise TextError(f"{value!r} is not a finite number")
        return repr(value)
    if isinstance(value, str):
        if _PLAIN.fullmatch(value) and value.lower() not in _RESERVED:
            return value
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{format_value(str(k))}: {format_value(v)}" for k, v in value.items()) + "}"
    raise TextError(f"cannot write {type(value).__name__} {value!r} into a patch")


def child(node, key):
    """(key node, value node) of `key` in a MappingNode, or item `key` of a SequenceNode as
    (None, node); None if absent."""
    if isinstance(node, MappingNode):
        for k, v in node.value:
            if isinstance(k, ScalarNode) and k.value == key:
                return k, v
        return None
    if isinstance(node, SequenceNode) and isinstance(key, int) and 0 <= key < len(node.value):
        return None, node.value[key]
    return None


def find(root, path):
    """The value node at `path` (keys and item numbers), or None."""
    node = root
    for key in path:
        found = child(node, key)
        if found is None:
            return None
        node = found[1]
    return node


def last_end(node):
    """Where the last scalar (or flow collection) inside `node` ends: a block collection's own
    end mark runs on over trailing comments, its last leaf's does not."""
    while isinstance(node, (MappingNode, SequenceNode)) and not node.flow_style and node.value:
        last = node.value[-1]
        node = last[1] if isinstance(node, MappingNode) else last
    return node.end_mark.index


def _line_start(text, index):
    return text.rfind("\n", 0, index) + 1


def _line_end(text, index):
    end = text.find("\n", index)
    return len(text) if end < 0 else end


def splice(text, start, end, new):
    return text[:start] + new + text[end:]


def replace_node(text, node, new):
    """`text` with the span of `node` replaced by `new`."""
    end = last_end(node) if isinstance(node, (MappingNode, SequenceNode)) and not node.flow_style else node.end_mark.index
    return splice(text, node.start_mark.index, end, new)


def _flow_close(text, node, bracket):
    """The index of the closing bracket of a flow collection."""
    close = text.rfind(bracket, node.start_mark.index, node.end_mark.index)
    if close < 0:
        raise TextError(f"no closing {bracket!r} at line {node.start_mark.line + 1}")
    return close


def _flow_insert(text, node, bracket, item):
    close = _flow_close(text, node, bracket)
    if not node.value:
        return splice(text, close, close, item)
    last = node.value[-1][1] if isinstance(node, MappingNode) else node.value[-1]
    end = last.end_mark.index
    return splice(text, end, end, ", " + item)


def _block_insert(text, node, column, item):
    """A new line `item` at `column` after the last line of the block collection `node`."""
    at = _line_end(text, last_end(node))
    return splice(text, at, at, "\n" + " " * column + item)


def set_key(text, path, key, value_text):
    """`key: value_text` in the mapping at `path`: its value's span replaced if the key is
    there, else the key added at the mapping's end in its style."""
    root = compose(text)
    mapping = find(root, path)
    if not isinstance(mapping, MappingNode):
        raise TextError(f"{'.'.join(map(str, path)) or 'the patch'} is not a mapping")
    found = child(mapping, key)
    if found is not None:
        return replace_node(text, found[1], value_text)
    if mapping.flow_style:
        return _flow_insert(text, mapping, "}", f"{key}: {value_text}")
    if not mapping.value:
        raise TextError(f"{'.'.join(map(str, path))} is empty")
    sep = ":" if value_text.startswith("\n") else ": "
    return _block_insert(text, mapping, mapping.value[0][0].start_mark.column, f"{key}{sep}{value_text}")


def remove_key(text, path, key):
    """The mapping at `path` without `key` (its line(s) in block style, `key: value` and a comma
    in flow style); `text` unchanged if the key is absent."""
    root = compose(text)
    mapping = find(root, path)
    found = child(mapping, key) if mapping is not None else None
    if found is None:
        return text
    k, v = found
    if mapping.flow_style:
        pairs = [p[0] for p in mapping.value]
        return _flow_remove(text, mapping, pairs.index(k), k.start_mark.index, _node_end(v), "}")
    return splice(text, _line_start(text, k.start_mark.index), _line_end(text, last_end(v)) + 1, "")


def _node_end(node):
    return node.end_mark.index if not isinstance(node, (MappingNode, SequenceNode)) or node.flow_style else last_end(node)


def _flow_remove(text, node, i, start, end, bracket):
    """Remove item i (span start..end) of a flow collection with its separating comma."""
    n = len(node.value)
    if n == 1:
        close = _flow_close(text, node, bracket)
        return splice(text, node.start_mark.index + 1, close, "")
    if i > 0:
        prev = node.value[i - 1]
        prev_end = _node_end(prev[1] if isinstance(node, MappingNode) else prev)
        return splice(text, prev_end, end, "")
    nxt = node.value[1]
    nxt_start = (nxt[0] if isinstance(node, MappingNode) else nxt).start_mark.index
    return splice(text, start, nxt_start, "")


def append_item(text, path, item_text):
    """`item_text` appended to the sequence at `path` (created as `[item]` under its mapping
    if missing)."""
    root = compose(text)
    seq = find(root, path)
    if seq is None:
        return set_key(text, path[:-1], path[-1], f"[{item_text}]")
    if not isinstance(seq, SequenceNode):
        raise TextError(f"{'.'.join(map(str, path))} is not a list")
    if seq.flow_style:
        return _flow_insert(text, seq, "]", item_text)
    if not seq.value:
        return replace_node(text, seq, f"[{item_text}]")
    return _block_insert(text, seq, seq.start_mark.column, f"- {item_text}")


def remove_item(text, path, i):
    """The sequence at `path` without its item i (its line in block style)."""
    root = compose(text)
    seq = find(root, path)
    if not isinstance(seq, SequenceNode) or not 0 <= i < len(seq.value):
        raise TextError(f"{'.'.join(map(str, path))} has no item {i}")
    item = seq.value[i]
    if seq.flow_style:
        return _flow_remove(text, seq, i, item.start_mark.index, _node_end(item), "]")
    if len(seq.value) == 1:
        return splice(text, seq.start_mark.index, last_end(seq), "[]")
    return splice(text, _line_start(text, item.start_mark.index), _line_end(text, _node_end(item)) + 1, "")


def scalar_text(node, value, in_flow):
    """New text for a string scalar, in its old quoting where that still reads back right."""
    if node is not None and node.style is None and not in_flow and "#" not in value and ": " not in value:
        return value
    return json.dumps(value, ensure_ascii=False)


def items(root, path):
    """The item nodes of the sequence at `path` ([] if none) and whether it is in flow style."""
    seq = find(root, path)
    if not isinstance(seq, SequenceNode):
        return [], False
    return list(seq.value), bool(seq.flow_style)


def block_list(entries, column):
    """A block-style sequence of flow items, starting on a new line indented by `column`."""
    return "".join("\n" + " " * column + "- " + format_value(e) for e in entries)
