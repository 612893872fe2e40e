"""Polyphony: a `voices:` template — blocks and their connections — copied `count` times into the
patch before anything else is checked, so every copy is an ordinary block of the one kernel.

    voices:
      count: 6                          # 1 … 128 copies, named v1_NAME … v6_NAME
      prefix: v                         # optional (default v)
      blocks:
        note: {type: midi_note, device: keys}      # allocated: voice 1 … 6 of 6
        str:  {type: vdelay, loop: 1.0}
        damp: {type: lowpass, gain: 0.996}
      connect:
        - note.freq -> str.frequency    # both ends in the template: inside each voice
        - str.out -> damp.in
        - damp.out -> str.in
        - str.out -> out.ch0            # one end a patch block: every voice adds into it
        - bright.out -> damp.gain       # or a patch block feeds every voice

An endpoint names a template block (that voice's copy) or a block of the patch (shared); since
several connections into one input sum, `str.out -> out.ch0` mixes the voices. A parameter
declared `refers="voice"` gets the copy's number (1 … count) and one declared `refers="voices"`
the count, so a voice-allocating block (midi_note) knows its place in the group. Problems found
later in a copy are reported once, at the template's line, under the template's names.
"""
import re

from .explain import describe, whole_errors
from .model import Endpoint
from .patterns import CONNECTION, IDENT
from .source import LDict, LList, line_of

SECTION = "voices"
DEFAULT_PREFIX = "v"     # v1_NAME, v2_NAME, … (a name prefix, not the port named v)
MAX_VOICES = 128


def voices_schema(block=None):
    """The section's JSON Schema; `block` (a block's schema) checks the template's blocks and
    the connections' syntax too (the published schema); without it, only the section's shape
    (the loader's first look: the copies are checked as blocks and connections of the patch)."""
    connection = {"type": "string", "pattern": CONNECTION} if block is not None else {"type": "string"}
    return {
        "type": "object", "required": ["count", "blocks"], "additionalProperties": False,
        "description": "a polyphonic voice: these blocks and connections copied `count` times",
        "properties": {
            "count": {"type": "integer", "minimum": 1, "maximum": MAX_VOICES, "description": "how many voices"},
            "prefix": {"type": "string", "pattern": IDENT, "default": DEFAULT_PREFIX,
                       "description": "the copies are named PREFIX1_NAME … PREFIXcount_NAME"},
            "blocks": {"type": "object", "minProperties": 1, "propertyNames": {"pattern": IDENT},
                       "additionalProperties": block if block is not None else {"type": "object"}},
            "connect": {"type": "array", "items": connection},
        },
    }


# blocks and connections the copies may add, checked before copying: a small file must not
# become a large document (the kernel's own limit, MAX_BLOCKS in graph/patch.py, comes later)
MAX_COPIES = 20_000


def expand(doc, registry, problems):
    """The document with its `voices:` template copied into `blocks:` and `connect:` (a copy
    without the section; the document itself when it has none)."""
    if SECTION not in doc:
        return doc
    out = _copy(doc, LDict)
    del out[SECTION]
    out.lines.pop(SECTION, None)
    group = _read(doc, registry, problems)
    if group is None:
        return out
    count, prefix, template, connect = group
    blocks = _copy(doc.get("blocks"), LDict)
    connections = _copy(doc.get("connect"), LList)
    taken = set(blocks)
    for k in range(1, count + 1):
        for name, spec in template.items():
            new = f"{prefix}{k}_{name}"
            if new in taken:
                problems.add(template.lines[name], f"voices: block {name!r} of voice {k} would be named "
                                                   f"{new!r}, a block of the patch; choose another `prefix`")
                continue
            blocks[new] = _numbered(spec, k, count, registry)
            blocks.lines[new] = template.lines[name]
    _connect(connect, count, prefix, set(template), connections, problems)
    out["blocks"], out["connect"] = blocks, connections
    out.lines.setdefault("blocks", doc.lines.get(SECTION, 1))
    out.lines.setdefault("connect", doc.lines.get(SECTION, 1))
    problems.folds.append(_fold(prefix, template, connect))
    return out


def _read(doc, registry, problems):
    """(count, prefix, template blocks, template connections) of a well-formed section, else
    None with its problems reported."""
    section = doc[SECTION]
    errors = list(whole_errors(voices_schema(), section))
    for err in errors:
        path = [SECTION] + list(err.absolute_path)
        problems.add(line_of(doc, path), describe(err, path, doc, registry))
    if errors:
        return None
    count, blocks = section["count"], section["blocks"]
    connect = section.get("connect") if isinstance(section.get("connect"), LList) else LList()
    if count * (len(blocks) + len(connect)) > MAX_COPIES:
        problems.add(section.lines.get("count", section.line),
                     f"voices: {count} copies of {len(blocks)} blocks and {len(connect)} connections make "
                     f"{count * (len(blocks) + len(connect)):,}; at most {MAX_COPIES:,} (docs/limits.md)")
        return None
    return count, section.get("prefix", DEFAULT_PREFIX), blocks, connect


def _numbered(spec, k, count, registry):
    """A copy of a template block for voice k (1 … count): its voice parameters set."""
    copy = _copy(spec, LDict)
    cls = registry.lookup(spec.get("type")) if isinstance(spec, LDict) else None
    for pname, param in (cls.params.items() if cls is not None else ()):
        value = {"voice": k, "voices": count}.get(param.refers)
        if value is not None:
            copy[pname] = value
            copy.lines.setdefault(pname, copy.line)
    return copy


def _connect(connect, count, prefix, names, out, problems):
    """Each template connection once per voice, its template ends renamed."""
    for text, line in zip(connect, connect.lines):
        left, _, right = text.partition("->")
        ends = (Endpoint.parse(left), Endpoint.parse(right))
        if None in ends:
            out.append(text)            # unreadable: the schema reports it, once
            out.lines.append(line)
            continue
        if not any(e.block in names for e in ends):
            problems.add(line, f"voices: connection {text.strip()!r} joins no block of the voice; "
                               f"it belongs under connect:")
            continue
        for k in range(1, count + 1):
            a, b = (Endpoint(f"{prefix}{k}_{e.block}" if e.block in names else e.block, e.index, e.port)
                    for e in ends)
            out.append(f"{a} -> {b}")
            out.lines.append(line)


def _fold(prefix, template, connect):
    """A Collector fold: a problem at a template line naming voice copies is told once, under
    the template's names."""
    lines = set(template.lines.values()) | set(connect.lines)
    for spec in template.values():
        lines |= set(getattr(spec, "lines", {}).values())
    names = "|".join(re.escape(n) for n in sorted(template, key=len, reverse=True))
    copies = re.compile(rf"\b{re.escape(prefix)}\d+_({names})\b")

    def fold(line, message):
        if line in lines and copies.search(message):
            return "voices: " + copies.sub(r"\1", message)
        return message
    return fold


def _copy(value, kind):
    out = kind(value) if isinstance(value, kind) else kind()
    out.line = getattr(value, "line", 1)
    src = getattr(value, "lines", None)
    if src is not None:
        out.lines = dict(src) if isinstance(src, dict) else list(src)
    return out


__all__ = ["MAX_VOICES", "SECTION", "expand", "voices_schema"]
