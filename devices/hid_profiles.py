"""HID device profiles: the YAML that says how a device's reports map to SI values (pure data).

A profile is read into frozen dataclasses and checked as a whole; every problem is reported as
`FILE:LINE: message` (a PatchError), so a patch that names a bad profile never starts. The
transport, the reader thread and the velocity estimator live in hapticgraph.devices.hid; this
module only parses, validates, decodes one field and encodes the force report; the hid driver
kind (hapticgraph.devices.kinds) hands the loader a device's ports from it.

Profile format (version 1)::

    hid_profile: 1                  # format version (required)
    name: haptic_1dof               # optional; defaults to the file's stem
    description: ...                # optional, free text
    vendor_id: 0x1209               # USB ids (a device entry may override them)
    product_id: 0x0001
    max_force: 4.0                  # N; required with an output report; the device's bound: every
                                    #   force is clamped to it, a device entry may only lower it
                                    #   (finite, > 0, at most MAX_FORCE = 1000 N, and what the field holds)
    input:
      report_id: 1                  # 0: the device numbers no reports (no id byte in front)
      length: 12                    # bytes of report data after the id byte
      interval: 0.001               # s between reports (for report-on-change devices: their polling interval)
      timeout: 0.05                 # optional, s: no report for longer = the device stopped answering
                                    #   (only for devices that stream; mice and gamepads report on change)
      position: pos                 # the axis that is the haptic block's x (optional: x = 0)
      velocity: vel                 # the axis that is v, or `estimate` (the default)
      velocity_cutoff: 100          # Hz, one-pole smoothing of the estimate (0: none; default 50)
      axes:                         # name -> field; every axis is an output port of the haptic block
        pos: {byte: 0, size: 32, signed: true, scale: 1.0e-6, unit: m}
        vel: {byte: 4, size: 16, signed: true, scale: 1.0e-4, unit: m/s}
      buttons:                      # name -> one bit; each is an output port (0 or 1)
        button1: {byte: 6, bit: 0}
    output:                         # optional: the report that carries the force
      report_id: 2
      length: 4
      force: {byte: 0, size: 16, signed: true, scale: 1000}   # counts per newton

A field: `byte` (offset into the report data, after the id byte), `bit` (0–7, default 0), `size`
(bits, 1–64; default 8 for an axis, 1 for a button), `signed` (two's complement, default false),
`endian` (little | big; big needs a whole number of bytes starting at bit 0; bit fields that
cross bytes are packed little-endian, as HID does), `scale` and `offset`: SI value =
(counts − offset) × scale, `relative: true` for axes that report a change (a mouse's counts):
their value is the running sum, `unit` (text, for people). For the force field, `scale` is
counts per newton: counts = round(force × scale), limited to what the field holds.
"""
import math
import os
import re
from dataclasses import dataclass

from ..blocks.device import Haptic
from ..graph.errors import PatchError
from ..graph.source import LDict, load_yaml

SUFFIXES = (".yaml", ".yml")
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")   # used with fullmatch: a name is matched whole
# names no axis or button may take: the haptic block's own ports, settings and sensor columns, the
# time, and `estimate` (the velocity setting's value)
RESERVED = ("t", *(d.name for d in Haptic.outputs + Haptic.inputs), *Haptic.params,
            *(e.attr for e in Haptic.externals), "estimate")
MAX_REPORT = 4096        # bytes; USB full speed interrupt reports are ≤ 64, high speed ≤ 1024
MAX_FORCE = 1000.0       # N: no profile may state more (the patch schema's bound on max_force)

TOP_KEYS = ("hid_profile", "name", "description", "vendor_id", "product_id", "max_force", "input", "output")
INPUT_KEYS = ("report_id", "length", "interval", "timeout", "position", "velocity", "velocity_cutoff",
              "axes", "buttons")
OUTPUT_KEYS = ("report_id", "length", "force")
AXIS_KEYS = ("byte", "bit", "size", "signed", "endian", "scale", "offset", "relative", "unit")
BUTTON_KEYS = ("byte", "bit")
FORCE_KEYS = ("byte", "bit", "size", "signed", "endian", "scale")


@dataclass(frozen=True)
class Field:
    """Where one value sits in a report and how its counts become SI units."""

    name: str
    byte: int
    bit: int = 0
    size: int = 8
    signed: bool = False
    endian: str = "little"
    scale: float = 1.0
    offset: float = 0.0
    relative: bool = False
    unit: str = ""
    line: int = 0

    @property
    def first_bit(self):
        return 8 * self.byte + self.bit

    @property
    def end_bit(self):
        return self.first_bit + self.size

    @property
    def span(self):
        """(first byte, bytes covered)."""
        return self.byte, (self.bit + self.size + 7) // 8

    def limits(self):
        """The smallest and largest count the field holds."""
        if self.signed:
            return -(1 << (self.size - 1)), (1 << (self.size - 1)) - 1
        return 0, (1 << self.size) - 1

    def counts(self, data):
        """The raw (integer) counts of this field in report data (the bytes after the id)."""
        start, n = self.span
        chunk = data[start:start + n]
        if self.endian == "big":
            raw = int.from_bytes(chunk, "big")
        else:
            raw = (int.from_bytes(chunk, "little") >> self.bit) & ((1 << self.size) - 1)
        if self.signed and raw >> (self.size - 1):
            raw -= 1 << self.size
        return raw

    def value(self, data):
        """SI value (for a relative axis: the change this report carries)."""
        return (self.counts(data) - self.offset) * self.scale

    def put(self, buf, at, counts):
        """Write integer counts into buf (a bytearray) with the field starting at byte `at`."""
        lo, hi = self.limits()
        counts = min(max(int(counts), lo), hi) & ((1 << self.size) - 1)
        start, n = self.span
        start += at
        if self.endian == "big":
            buf[start:start + n] = counts.to_bytes(n, "big")
            return
        mask = ((1 << self.size) - 1) << self.bit
        word = int.from_bytes(buf[start:start + n], "little")
        word = (word & ~mask) | (counts << self.bit)
        buf[start:start + n] = word.to_bytes(n, "little")


@dataclass(frozen=True)
class InputReport:
    report_id: int
    length: int
    interval: float
    axes: tuple
    buttons: tuple
    timeout: float = None
    position: str = None
    velocity: str = "estimate"
    velocity_cutoff: float = 50.0

    @property
    def read_size(self):
        """Bytes hidapi returns for one report: the id byte (numbered reports) and the data."""
        return self.length + (1 if self.report_id else 0)

    def data(self, report):
        """The report's data (after the id byte), or None if it is another report or too short."""
        if self.report_id:
            if len(report) < 1 or report[0] != self.report_id:
                return None
            report = report[1:]
        if len(report) < self.length:
            return None
        return report

    def axis(self, name):
        for f in self.axes:
            if f.name == name:
                return f
        return None


@dataclass(frozen=True)
class OutputReport:
    report_id: int
    length: int
    force: Field

    def buffer(self):
        """A zeroed report as hidapi writes it: the id byte (0 for unnumbered reports), then the data."""
        buf = bytearray(1 + self.length)
        buf[0] = self.report_id
        return buf

    def encode(self, force, buf=None):
        """The report carrying `force` [N] (already clamped by the caller); rounds to counts."""
        buf = self.buffer() if buf is None else buf
        self.force.put(buf, 1, round(force * self.force.scale))
        return buf

    def decode(self, report):
        """The force [N] a written report carries (for tests and replays)."""
        return self.force.counts(bytes(report[1:])) / self.force.scale


@dataclass(frozen=True)
class Profile:
    name: str
    file: str
    vendor_id: int
    product_id: int
    input: InputReport
    output: OutputReport = None
    max_force: float = 0.0
    description: str = ""

    @property
    def ports(self):
        """The haptic block's extra output ports: every axis, then every button, in file order."""
        return tuple(f.name for f in self.input.axes) + tuple(f.name for f in self.input.buttons)


# -- where profiles are -------------------------------------------------------------------------

def shipped_dir():
    """The folder of the profiles shipped with the package (package data beside this module)."""
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "profiles")


def shipped_profiles():
    """Names of the shipped profiles."""
    folder = shipped_dir()
    try:
        return sorted(os.path.splitext(f)[0] for f in os.listdir(folder) if f.endswith(SUFFIXES))
    except OSError:
        return []


def find_profile(ref, base=None):
    """The file a device entry's `profile:` names: a shipped profile's name (`gamepad`) or a
    .yaml file (relative to `base`, the patch's folder). None if there is none."""
    ref = str(ref)
    if ref.endswith(SUFFIXES) or "/" in ref or os.sep in ref:
        path = ref if os.path.isabs(ref) else os.path.join(base or os.getcwd(), ref)
        return path if os.path.isfile(path) else None
    if not IDENT.fullmatch(ref):
        return None
    path = os.path.join(shipped_dir(), ref + ".yaml")
    return path if os.path.isfile(path) else None


def load_profile(path):
    """Parse and check a profile file; raises PatchError listing every problem (FILE:LINE)."""
    doc, problems = load_yaml(path)
    profile = None
    if doc is not None:
        profile = _parse(doc, path, problems)
    problems.raise_if_any()
    return profile


def profile_of(spec, base=None):
    """The Profile of a `driver: hid` device entry: the one the loader attached, else loaded by
    name; None if it cannot be loaded (the loader has reported why)."""
    profile = getattr(spec, "hid_profile", None)
    if profile is not None:
        return profile
    path = find_profile(spec.get("profile", ""), base) if isinstance(spec.get("profile"), str) else None
    if path is None:
        return None
    try:
        return load_profile(path)
    except PatchError:
        return None


# -- parsing and checking ------------------------------------------------------------------------

def _line(node, key):
    return node.lines.get(key, node.line) if isinstance(node, LDict) else getattr(node, "line", 1)


def _is_int(v):
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class _Checker:
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
            self.add(_line(node, key), f"{where}.{key}: expected a mapping")
            return None
        value.line = _line(node, key)     # problems of the whole mapping point at its key
        return value

    def integer(self, node, key, where, lo, hi, default=None, required=False):
        if key not in node:
            if required:
                self.add(node.line, f"{where}: missing {key!r}")
            return default
        v = node[key]
        if not _is_int(v):
            self.add(_line(node, key), f"{where}.{key}: {v!r} is not a whole number")
            return default
        if not lo <= v <= hi:
            self.add(_line(node, key), f"{where}.{key}: {v} is outside {lo} … {hi}")
            return default
        return v

    def number(self, node, key, where, default=None, required=False, positive=False, nonneg=False,
               nonzero=False):
        if key not in node or node[key] is None:
            if required:
                self.add(node.line, f"{where}: missing {key!r}")
            return default
        v = node[key]
        if not _is_num(v):
            self.add(_line(node, key), f"{where}.{key}: {v!r} is not a number")
            return default
        if positive and v <= 0:
            self.add(_line(node, key), f"{where}.{key}: {v!r} must be greater than 0")
            return default
        if nonneg and v < 0:
            self.add(_line(node, key), f"{where}.{key}: {v!r} must not be negative")
            return default
        if nonzero and v == 0:
            self.add(_line(node, key), f"{where}.{key}: must not be 0")
            return default
        return float(v)

    def boolean(self, node, key, where, default=False):
        if key not in node:
            return default
        if not isinstance(node[key], bool):
            self.add(_line(node, key), f"{where}.{key}: {node[key]!r} is not true or false")
            return default
        return node[key]

    def text(self, node, key, where, default=""):
        if key not in node or node[key] is None:
            return default
        if not isinstance(node[key], str):
            self.add(_line(node, key), f"{where}.{key}: {node[key]!r} is not text")
            return default
        return node[key]


def _field(chk, name, node, where, keys, default_size, length, line):
    """One field; None if it has a problem (reported)."""
    if not isinstance(node, LDict):
        chk.add(line, f"{where}: expected a mapping such as {{byte: 0, size: 8}}")
        return None
    before = chk.ok
    chk.ok = True
    chk.keys(node, keys, where)
    byte = chk.integer(node, "byte", where, 0, MAX_REPORT - 1, required=True)
    bit = chk.integer(node, "bit", where, 0, 7, default=0)
    size = default_size
    if "size" in node:
        size = node["size"]
        if not _is_int(size) or not 1 <= size <= 64:
            chk.add(_line(node, "size"), f"{where}.size: {size!r} is not a size in bits from 1 to 64")
            size = None
    signed = chk.boolean(node, "signed", where)
    endian = chk.text(node, "endian", where, "little")
    if endian not in ("little", "big"):
        chk.add(_line(node, "endian"), f"{where}.endian: {endian!r} is not little or big")
    scale = chk.number(node, "scale", where, 1.0, nonzero=True)
    offset = chk.number(node, "offset", where, 0.0)
    relative = chk.boolean(node, "relative", where)
    unit = chk.text(node, "unit", where)
    if size is not None and signed and size < 2:
        chk.add(_line(node, "signed"), f"{where}: a signed field needs at least 2 bits")
    if endian == "big" and size is not None and bit is not None and (bit or size % 8):
        chk.add(_line(node, "endian"), f"{where}: endian big needs whole bytes at bit 0 "
                                       f"(bit {bit}, size {size}); bit fields are packed little-endian")
    if byte is not None and bit is not None and size is not None and length is not None:
        end = 8 * byte + bit + size
        if end > 8 * length:
            chk.add(node.line, f"{where}: bits {8 * byte + bit}…{end - 1} (byte {byte}, bit {bit}, size {size}) "
                               f"lie outside the report of {length} byte(s)")
    ok, chk.ok = chk.ok, before and chk.ok
    if not ok:
        return None
    return Field(name, byte, bit, size, signed, endian, scale if scale is not None else 1.0,
                 offset if offset is not None else 0.0, relative, unit, node.line)


def _overlaps(chk, fields, what):
    spans = sorted(fields, key=lambda f: (f.first_bit, f.line))
    for a, i in zip(spans, range(len(spans))):
        for b in spans[i + 1:]:
            if b.first_bit >= a.end_bit:
                break
            first, second = sorted((a, b), key=lambda f: f.line)
            chk.add(second.line, f"{what}: field {second.name!r} (bits {second.first_bit}…{second.end_bit - 1}) "
                                 f"overlaps {first.name!r} (bits {first.first_bit}…{first.end_bit - 1}, "
                                 f"line {first.line})")


def _fields(chk, node, key, where, keys, default_size, length, names):
    group = node.get(key)
    if group is None:
        return []
    if not isinstance(group, LDict):
        chk.add(_line(node, key), f"{where}.{key}: expected a mapping of name -> field")
        return []
    out = []
    for name, spec in group.items():
        line = group.lines[name]
        here = f"{where}.{key}.{name}"
        if not IDENT.fullmatch(str(name)):
            chk.add(line, f"{here}: {name!r} is not a port name (letters, digits, _)")
            continue
        if name in RESERVED:
            chk.add(line, f"{here}: {name!r} is reserved (the haptic block's own ports and settings: "
                          f"{', '.join(RESERVED)}); choose another name")
            continue
        if name in names:
            chk.add(line, f"{here}: the name {name!r} is used twice (first at line {names[name]})")
            continue
        names[name] = line
        if isinstance(spec, LDict):
            spec.line = line
        f = _field(chk, name, spec, here, keys, default_size, length, line)
        if f is not None:
            out.append(f)
    return out


def _parse(doc, path, problems):
    chk = _Checker(problems)
    if not isinstance(doc, LDict):
        chk.add(getattr(doc, "line", 1), "a HID profile is a mapping starting with `hid_profile: 1`")
        return None
    if doc.get("hid_profile") != 1:
        chk.add(_line(doc, "hid_profile"), "the first key must be `hid_profile: 1` (the profile format version)"
                if "hid_profile" not in doc else f"unsupported HID profile version {doc['hid_profile']!r}; "
                                                 "this hapticgraph reads version 1")
    chk.keys(doc, TOP_KEYS, "profile")
    name = chk.text(doc, "name", "profile", os.path.splitext(os.path.basename(path))[0])
    description = chk.text(doc, "description", "profile")
    vid = chk.integer(doc, "vendor_id", "profile", 0, 0xFFFF, required=True)
    pid = chk.integer(doc, "product_id", "profile", 0, 0xFFFF, required=True)
    max_force = chk.number(doc, "max_force", "profile", None, positive=True)
    if max_force is not None and max_force > MAX_FORCE:
        chk.add(_line(doc, "max_force"), f"profile.max_force: {max_force:g} N is above {MAX_FORCE:g} N, "
                                         "the most any device may state")
        max_force = None

    inp = chk.mapping(doc, "input", "profile")
    report = None
    if inp is not None:
        chk.keys(inp, INPUT_KEYS, "input")
        rid = chk.integer(inp, "report_id", "input", 0, 255, default=0)
        length = chk.integer(inp, "length", "input", 1, MAX_REPORT, required=True)
        interval = chk.number(inp, "interval", "input", None, required=True, positive=True)
        timeout = chk.number(inp, "timeout", "input", None, positive=True)
        if timeout is not None and interval is not None and timeout <= interval:
            chk.add(_line(inp, "timeout"), f"input.timeout: {timeout:g} s must be longer than the report "
                                           f"interval {interval:g} s")
        cutoff = chk.number(inp, "velocity_cutoff", "input", 50.0, nonneg=True)
        names = {}
        axes = _fields(chk, inp, "axes", "input", AXIS_KEYS, 8, length, names)
        buttons = _fields(chk, inp, "buttons", "input", BUTTON_KEYS, 1, length, names)
        if not axes and not buttons and "axes" not in inp and "buttons" not in inp:
            chk.add(inp.line, "input: no axes and no buttons: the device would give nothing")
        _overlaps(chk, axes + buttons, "input")
        position = chk.text(inp, "position", "input", None)
        velocity = chk.text(inp, "velocity", "input", "estimate")
        axis_names = [f.name for f in axes]
        declared = set(inp.get("axes") or ()) if isinstance(inp.get("axes"), LDict) else set()
        for key, value in (("position", position), ("velocity", velocity)):
            if value is None or (key == "velocity" and value == "estimate"):
                continue
            if value not in declared:
                other = " or `estimate`" if key == "velocity" else ""
                chk.add(_line(inp, key), f"input.{key}: no axis named {value!r} "
                                         f"(axes: {', '.join(axis_names) or 'none'}){other}")
        if velocity == "estimate" and position is None and "velocity" in inp:
            chk.add(_line(inp, "velocity"), "input.velocity: `estimate` needs a `position` axis")
        if chk.ok:
            report = InputReport(rid, length, interval, tuple(axes), tuple(buttons), timeout, position,
                                 velocity, cutoff)

    out = None
    outp = chk.mapping(doc, "output", "profile", required=False)
    if outp is not None:
        chk.keys(outp, OUTPUT_KEYS, "output")
        rid = chk.integer(outp, "report_id", "output", 0, 255, default=0)
        length = chk.integer(outp, "length", "output", 1, MAX_REPORT, required=True)
        force_node = outp.get("force")
        force = None
        if force_node is None:
            chk.add(outp.line, "output: missing 'force' (the field that carries the force)")
        else:
            if isinstance(force_node, LDict):
                force_node.line = _line(outp, "force")
            force = _field(chk, "force", force_node, "output.force", FORCE_KEYS, 16, length, _line(outp, "force"))
        if max_force is None and "max_force" not in doc:
            chk.add(outp.line, "profile: a device with a force output needs `max_force` [N], "
                               "the limit every force is clamped to")
        if force is not None and max_force is not None:
            lo, hi = force.limits()
            top = min(abs(lo / force.scale), abs(hi / force.scale)) if force.signed else abs(hi / force.scale)
            if max_force > top * (1 + 1e-9):
                chk.add(_line(doc, "max_force"), f"max_force {max_force:g} N does not fit the output's force "
                                                 f"field (at most {top:g} N with scale {force.scale:g})")
        if force is not None and chk.ok:
            out = OutputReport(rid, length, force)
    if not chk.ok or report is None:
        return None
    return Profile(name, path, vid, pid, report, out, max_force or 0.0, description)


__all__ = ["MAX_FORCE", "Field", "InputReport", "OutputReport", "Profile", "find_profile", "load_profile",
           "profile_of", "shipped_dir", "shipped_profiles"]
