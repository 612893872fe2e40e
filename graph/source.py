"""YAML read safely into dicts and lists that remember the line of every key and item.

The parser's events are composed here rather than by PyYAML's composer and constructor, so every
guard acts while the file is read, before the work it would cost (docs/limits.md lists them):
only a regular file of at most MAX_BYTES, UTF-8 text; nesting at most MAX_DEPTH; every value
built, every alias expanded and every merge (`<<`) source charged against MAX_NODES before it is
copied, so an alias or merge bomb stops at once; recursive aliases refused; duplicate keys; no
tags (`!!python/...`, `!!binary`, `!custom`); numbers finite and at most MAX_DIGITS long. Plain
scalars are read as in YAML 1.2's core schema: only true/false are booleans, so `on:`, `no:`,
`yes:` and `off:` are the strings they look like. Reading stops as soon as the Collector is full.
"""
import math
import os
import re
import stat

import yaml

from .errors import Collector

MAX_BYTES = 4 * 1024 * 1024
MAX_NODES = 200_000
MAX_DEPTH = 64
MAX_DIGITS = 100

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)   # only its parser (events) is used

_NULL = frozenset(("", "~", "null", "Null", "NULL"))
_BOOL = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}
_INT = re.compile(r"[-+]?[0-9]+")
_OCT = re.compile(r"0o[0-7]+")
_HEX = re.compile(r"0x[0-9a-fA-F]+")
_FLOAT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?")
_SPECIAL = re.compile(r"[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)")


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


class _Stop(Exception):
    """Reading stops: a budget is spent or the Collector is full (the problem is recorded)."""


def _kind(mode):
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def read_text(path, problems):
    """The file's text, or None with a problem recorded. Only a regular file is opened, and
    without blocking, so a FIFO or a device given as a patch is refused, never waited on."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            problems.add(1, f"the patch is {_kind(info.st_mode)}, not a regular file")
            return None
        if info.st_size > MAX_BYTES:
            problems.add(1, f"file is {info.st_size / 1e6:.1f} MB; a patch may be at most "
                            f"{MAX_BYTES // (1024 * 1024)} MB")
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
        with os.fdopen(fd, "rb") as f:
            mode = os.fstat(f.fileno()).st_mode   # swapped for something else since the stat?
            if not stat.S_ISREG(mode):
                problems.add(1, f"the patch is {_kind(mode)}, not a regular file")
                return None
            data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        problems.add(1, f"cannot read the patch: {exc.strerror or exc}")
        return None
    if len(data) > MAX_BYTES:
        problems.add(1, f"a patch may be at most {MAX_BYTES // (1024 * 1024)} MB")
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
    loader = _Loader(text)
    try:
        loader.get_event()                                  # stream start
        if loader.check_event(yaml.StreamEndEvent):
            problems.add(1, "the patch is empty")
            return None
        loader.get_event()                                  # document start
        before = len(problems.problems)
        value, _, _ = _Composer(loader, problems).node(0)
        if value is None and len(problems.problems) > before:
            return None                                     # refused, and reported
        loader.get_event()                                  # document end
        if not loader.check_event(yaml.StreamEndEvent):
            problems.add(loader.peek_event().start_mark.line + 1,
                         "a second YAML document starts here; a patch is one document")
            return None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        if "nesting depth" in str(exc.problem):    # libyaml's own limit, met while scanning ahead
            problems.add(mark.line + 1 if mark else 1,
                         f"the document is nested too deeply (more than {MAX_DEPTH} levels)")
        else:
            problems.add(mark.line + 1 if mark else 1, f"YAML syntax: {exc.problem or exc}")
        return None
    except yaml.YAMLError as exc:
        problems.add(1, f"YAML: {exc}")
        return None
    except _Stop:
        return None
    finally:
        loader.dispose()
    if value is None:
        problems.add(1, "the patch is empty")
    return value


def parse_value(text, problems, line):
    """A value given outside the file (`--set B.P=VALUE`), read by the same guarded path; its
    problems and its items are placed at `line`. (ok, value)."""
    inner = Collector(problems.file)
    value = None
    if text.strip():
        value = parse(text, inner)
        if [p.message for p in inner.problems] == ["the patch is empty"]:
            inner.problems, value = [], None     # `B.P=# comment`: null, like `B.P=`
    for p in inner.problems:
        problems.add(line, p.message)
    _place(value, line)
    return not inner.problems, value


def _place(value, line):
    if isinstance(value, LDict):
        value.line, value.lines = line, {k: line for k in value}
    elif isinstance(value, LList):
        value.line, value.lines = line, [line] * len(value)
    for item in value.values() if isinstance(value, LDict) else value if isinstance(value, LList) else ():
        _place(item, line)


def _copy(value):
    if isinstance(value, LDict):
        out = LDict((k, _copy(v)) for k, v in value.items())
        out.line, out.lines = value.line, dict(value.lines)
        return out
    if isinstance(value, LList):
        out = LList(_copy(v) for v in value)
        out.line, out.lines = value.line, list(value.lines)
        return out
    return value


class _Composer:
    """Parser events -> values; `node` returns (value, cost, height): cost is the work the value
    took (values built, aliases copied, merge sources read), charged again at every alias."""

    def __init__(self, events, problems):
        self.events, self.problems = events, problems
        self.anchors = {}          # name -> (value, cost, height)
        self.open = set()          # anchors whose value is still being read
        self.count = 0

    def add(self, line, message):
        self.problems.add(line, message)
        if self.problems.full:
            self.problems.stop(line)
            raise _Stop

    def charge(self, cost, line):
        self.count += cost
        if self.count > MAX_NODES:
            self.problems.add(line, f"the document expands to more than {MAX_NODES:,} values "
                                    "(an alias bomb or merge bomb?); refusing to expand it")
            raise _Stop

    def node(self, depth):
        ev = self.events.get_event()
        line = ev.start_mark.line + 1
        if depth > MAX_DEPTH:
            self.problems.add(line, f"the document is nested too deeply (more than {MAX_DEPTH} levels)")
            raise _Stop
        if isinstance(ev, yaml.AliasEvent):
            return self.alias(ev, depth, line)
        anchor = ev.anchor
        if anchor is not None:
            self.open.add(anchor)
        self.charge(1, line)
        if isinstance(ev, yaml.ScalarEvent):
            value, cost, height = self.scalar(ev, line), 1, 0
        elif isinstance(ev, yaml.SequenceStartEvent):
            value, cost, height = self.sequence(depth, line)
        else:
            value, cost, height = self.mapping(depth, line)
        if ev.tag is not None:
            self.add(line, f"tags are not allowed in a patch (found {ev.tag!r})")
            value = None
        if anchor is not None:
            self.open.discard(anchor)
            self.anchors[anchor] = (value, cost, height)
        return value, cost, height

    def alias(self, ev, depth, line):
        name = ev.anchor
        if name in self.open:
            self.add(line, f"*{name} is used inside the value &{name} names (a recursive structure)")
            return None, 1, 0
        if name not in self.anchors:
            self.add(line, f"*{name}: no anchor &{name} before this")
            return None, 1, 0
        value, cost, height = self.anchors[name]
        self.charge(cost, line)
        if depth + height > MAX_DEPTH:
            self.problems.add(line, f"the document is nested too deeply (more than {MAX_DEPTH} levels)")
            raise _Stop
        return _copy(value), cost, height

    def sequence(self, depth, line):
        out = LList()
        out.line = line
        cost, height = 1, 0
        while not self.events.check_event(yaml.SequenceEndEvent):
            item_line = self.events.peek_event().start_mark.line + 1
            value, c, h = self.node(depth + 1)
            out.append(value)
            out.lines.append(item_line)
            cost, height = cost + c, max(height, h + 1)
        self.events.get_event()
        return out, cost, height

    def mapping(self, depth, line):
        out = LDict()
        out.line = line
        cost, height = 1, 0
        merges = []
        while not self.events.check_event(yaml.MappingEndEvent):
            kev = self.events.peek_event()
            key_line = kev.start_mark.line + 1
            if isinstance(kev, yaml.ScalarEvent) and kev.tag is None:
                if not kev.style and kev.value == "<<" and kev.anchor is None:
                    self.events.get_event()
                    value, c, h = self.node(depth + 1)
                    merges.append((key_line, value))
                    cost, height = cost + c, max(height, h)
                    continue
                self.events.get_event()     # a key is its text: `1:`, `on:`, `null:` are strings
                self.charge(1, key_line)
                key = kev.value
                if kev.anchor is not None:
                    self.anchors[kev.anchor] = (key, 1, 0)
            else:
                key, c, _ = self.node(depth + 1)   # a tagged key is reported there
                cost += c
                if isinstance(kev, yaml.AliasEvent) and isinstance(key, str):
                    pass
                elif isinstance(kev, yaml.AliasEvent) or kev.tag is None:     # an alias has no tag
                    self.add(key_line, "a key must be a plain string")
                    key = None
                else:
                    key = None
            value, c, h = self.node(depth + 1)
            cost, height = cost + c, max(height, h + 1)
            if key is None:
                continue
            if key in out:
                self.add(key_line, f"duplicate key {key!r} (first at line {out.lines[key]})")
                continue
            out[key] = value
            out.lines[key] = key_line
        self.events.get_event()
        self.merge(out, merges)
        return out, cost, height

    def merge(self, out, merges):
        """Merge keys (<<): explicit keys win, then the earlier source."""
        for merge_line, source in merges:
            sources = source if isinstance(source, LList) else [source]
            for item in sources:
                if item is None:
                    continue            # a refused value, reported where it was read
                if not isinstance(item, LDict):
                    self.add(merge_line, "a merge key (<<) needs a mapping or a list of mappings")
                    continue
                for k, v in item.items():
                    if k not in out:
                        out[k] = v
                        out.lines[k] = item.lines.get(k, merge_line)

    def scalar(self, ev, line):
        text = ev.value
        if ev.style or ev.tag is not None:
            return text                 # quoted or block: a string (a tag is reported by the caller)
        if text in _NULL:
            return None
        if text in _BOOL:
            return _BOOL[text]
        if _SPECIAL.fullmatch(text):
            self.add(line, f"{text!r}: numbers must be finite")
            return None
        kind = next((k for k, rx in (("int", _INT), ("float", _FLOAT), ("oct", _OCT), ("hex", _HEX))
                     if rx.fullmatch(text)), None)
        if kind is None:
            return text
        if len(text) > MAX_DIGITS:
            self.add(line, f"a number {len(text)} characters long; a patch's numbers have at most "
                           f"{MAX_DIGITS} digits")
            return None
        if kind != "float":
            return int(text, {"int": 10, "oct": 0, "hex": 0}[kind])
        value = float(text)
        if not math.isfinite(value):
            self.add(line, f"{text!r}: numbers must be finite")
            return None
        return value


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


def load_yaml(path, text=None):
    """(document, problems) for a patch file; `text`, when given, is read instead of the file
    (an edited patch not yet saved: problems still name `path`)."""
    problems = Collector(path)
    if text is None:
        text = read_text(path, problems)
    elif len(text) > MAX_BYTES or "\x00" in text:
        problems.add(1, f"a patch is text of at most {MAX_BYTES // (1024 * 1024)} MB")
        text = None
    doc = parse(text, problems) if text is not None else None
    return doc, problems
