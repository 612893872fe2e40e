"""YAML read safely into dicts and lists that remember the line of every key and item.

Guards: a size limit read before parsing, text-only input, a depth limit, duplicate keys, and
a budget on the nodes built, so an alias bomb ("billion laughs") fails fast instead of
expanding. Numbers must be finite.
"""
import math
import os
import re

import yaml

from .errors import Collector

MAX_BYTES = 4 * 1024 * 1024
MAX_NODES = 200_000
MAX_DEPTH = 64


class PatchLoader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as `1e-3` (YAML 1.1 wants `1.0e-3`)."""


PatchLoader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
PatchLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."))


class LDict(dict):
    """A mapping from the patch; `line` is where it starts, `lines[key]` where each key is."""

    line = 1

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.lines = {}


class LList(list):
    """A sequence from the patch; `line` is where it starts, `lines[i]` where each item is."""

    line = 1

    def __init__(self, *args):
        super().__init__(*args)
        self.lines = []


class _Budget(Exception):
    def __init__(self, line, message):
        super().__init__(message)
        self.line, self.message = line, message


def read_text(path, problems):
    """The file's text, or None with a problem recorded."""
    try:
        size = os.path.getsize(path)
        if size > MAX_BYTES:
            problems.add(1, f"file is {size / 1e6:.1f} MB; a patch may be at most {MAX_BYTES // (1024 * 1024)} MB")
            return None
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        problems.add(1, f"cannot read the patch: {exc.strerror or exc}")
        return None
    if b"\x00" in data:
        problems.add(1, "this is a binary file, not a YAML patch")
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        problems.add(line, "the patch is not UTF-8 text")
        return None


def parse(text, problems):
    """Parse YAML text into LDict/LList/scalars; None (with problems recorded) if it cannot."""
    loader = PatchLoader(text)
    try:
        node = loader.get_single_node()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problems.add(mark.line + 1 if mark else 1, f"YAML syntax: {exc.problem or exc}")
        return None
    except yaml.YAMLError as exc:
        problems.add(1, f"YAML: {exc}")
        return None
    except RecursionError:
        problems.add(1, f"the document is nested too deeply (more than {MAX_DEPTH} levels)")
        return None
    finally:
        loader.dispose()
    if node is None:
        problems.add(1, "the patch is empty")
        return None
    count = [0]
    try:
        return _build(node, loader, count, 0, problems)
    except _Budget as exc:
        problems.add(exc.line, exc.message)
        return None


def _build(node, loader, count, depth, problems):
    count[0] += 1
    line = node.start_mark.line + 1
    if count[0] > MAX_NODES:
        raise _Budget(line, f"the document expands to more than {MAX_NODES} values "
                            "(an alias bomb?); refusing to expand it")
    if depth > MAX_DEPTH:
        raise _Budget(line, f"the document is nested too deeply (more than {MAX_DEPTH} levels)")
    if isinstance(node, yaml.MappingNode):
        out = LDict()
        out.line = line
        for key_node, value_node in _merged(node, problems):
            if not isinstance(key_node, yaml.ScalarNode):
                problems.add(key_node.start_mark.line + 1, "a key must be a plain string")
                continue
            key = str(loader.construct_object(key_node))
            key_line = key_node.start_mark.line + 1
            if key in out:
                problems.add(key_line, f"duplicate key {key!r} (first at line {out.lines[key]})")
                continue
            out[key] = _build(value_node, loader, count, depth + 1, problems)
            out.lines[key] = key_line
        return out
    if isinstance(node, yaml.SequenceNode):
        out = LList()
        out.line = line
        for item in node.value:
            out.append(_build(item, loader, count, depth + 1, problems))
            out.lines.append(item.start_mark.line + 1)
        return out
    try:
        value = loader.construct_object(node)
    except yaml.YAMLError as exc:
        problems.add(line, f"bad value: {exc}")
        return None
    if isinstance(value, float) and not math.isfinite(value):
        problems.add(line, f"{node.value!r}: numbers must be finite")
        return None
    if not isinstance(value, (str, int, float, bool, type(None))):
        return str(node.value)   # dates and binary tags are kept as their text
    return value


def _merged(node, problems):
    """Key/value node pairs with YAML merge keys (`<<: *base`) applied; explicit keys win."""
    explicit, merged = [], []
    for key_node, value_node in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            sources = value_node.value if isinstance(value_node, yaml.SequenceNode) else [value_node]
            for source in sources:
                if isinstance(source, yaml.MappingNode):
                    merged.extend(_merged(source, problems))
                else:
                    problems.add(source.start_mark.line + 1, "a merge key (<<) needs a mapping")
        else:
            explicit.append((key_node, value_node))
    names = {k.value for k, _ in explicit if isinstance(k, yaml.ScalarNode)}
    seen = set()
    out = list(explicit)
    for k, v in merged:
        if isinstance(k, yaml.ScalarNode) and (k.value in names or k.value in seen):
            continue
        seen.add(getattr(k, "value", None))
        out.append((k, v))
    return out


def line_of(doc, path):
    """The line of the value at `path` (keys and indices) in a parsed document: the deepest known."""
    line = getattr(doc, "line", 1)
    node = doc
    for step in path:
        if isinstance(node, LDict) and step in node:
            line = node.lines.get(step, line)
            node = node[step]
        elif isinstance(node, LList) and isinstance(step, int) and 0 <= step < len(node):
            line = node.lines[step]
            node = node[step]
        else:
            break
    return line


def load_yaml(path):
    """(document, problems) for a patch file."""
    problems = Collector(path)
    text = read_text(path, problems)
    doc = parse(text, problems) if text is not None else None
    return doc, problems
