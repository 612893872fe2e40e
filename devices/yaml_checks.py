"""Checks of the values of a YAML mapping read with line numbers (graph.source's LDict): each
problem is added to a Collector as `FILE:LINE: where.key: message`, and the check gives back the
value or a default so the caller goes on and reports every problem at once."""
import math

from ..blocks.numbers import is_whole, whole_number
from ..graph.source import LDict


def line_of(node, key):
    return node.lines.get(key, node.line) if isinstance(node, LDict) else getattr(node, "line", 1)


def is_int(v):
    """An integer as a profile means one: an int, or a float without fraction (2.0)."""
    return is_whole(v)


def is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class Checker:
    """Checks values and keys of LDict nodes; `ok` turns False at the first problem."""

    def __init__(self, problems):
        self.problems = problems
        self.ok = True

    def add(self, line, message):
        self.problems.add(line, message)
        self.ok = False

    def keys(self, node, allowed, where):
        for key in node:
            if key not in allowed:
                close = [a for a in allowed if a.startswith(str(key)[:3])]
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                self.add(node.lines[key], f"{where}: unknown key {key!r}{hint}; allowed: {', '.join(allowed)}")

    def mapping(self, node, key, where, required=True):
        value = node.get(key)
        if value is None:
            if required:
                self.add(node.line, f"{where}: missing {key!r}")
            return None
        if not isinstance(value, LDict):
            self.add(line_of(node, key), f"{where}.{key}: expected a mapping")
            return None
        value.line = line_of(node, key)     # problems of the whole mapping point at its key
        return value

    def integer(self, node, key, where, lo, hi, default=None, required=False):
        if key not in node:
            if required:
                self.add(node.line, f"{where}: missing {key!r}")
            return default
        try:
            v = whole_number(node[key])       # 2.0 is 2; 2.5 is refused, named
        except ValueError as exc:
            self.add(line_of(node, key), f"{where}.{key}: {exc}")
            return default
        if not lo <= v <= hi:
            self.add(line_of(node, key), f"{where}.{key}: {v} is outside {lo} … {hi}")
            return default
        return v

    def number(self, node, key, where, default=None, required=False, positive=False, nonneg=False,
               nonzero=False):
        if key not in node or node[key] is None:
            if required:
                self.add(node.line, f"{where}: missing {key!r}")
            return default
        v = node[key]
        if not is_num(v):
            self.add(line_of(node, key), f"{where}.{key}: {v!r} is not a number")
            return default
        if positive and v <= 0:
            self.add(line_of(node, key), f"{where}.{key}: {v!r} must be greater than 0")
            return default
        if nonneg and v < 0:
            self.add(line_of(node, key), f"{where}.{key}: {v!r} must not be negative")
            return default
        if nonzero and v == 0:
            self.add(line_of(node, key), f"{where}.{key}: must not be 0")
            return default
        return float(v)

    def boolean(self, node, key, where, default=False):
        if key not in node:
            return default
        if not isinstance(node[key], bool):
            self.add(line_of(node, key), f"{where}.{key}: {node[key]!r} is not true or false")
            return default
        return node[key]

    def text(self, node, key, where, default=""):
        if key not in node or node[key] is None:
            return default
        if not isinstance(node[key], str):
            self.add(line_of(node, key), f"{where}.{key}: {node[key]!r} is not text")
            return default
        return node[key]


__all__ = ["Checker", "is_int", "is_num", "line_of"]
