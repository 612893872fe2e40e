"""HID device profiles: the YAML that says how a device's reports map to SI values (pure data).

A profile is read into frozen dataclasses and checked as a whole; every problem is reported as
`FILE:LINE: message` (a PatchError), so a patch that names a bad profile never starts. This
module finds, parses and checks profiles; the dataclasses they become, with the decoding of one
field and the encoding of the force report, are in hapticgraph.devices.hid_reports; the
transports in hapticgraph.devices.hid_transports; the reader thread in hapticgraph.devices.hid.
The hid driver kind (hapticgraph.devices.hid_kind) hands the loader a device's ports from here.

Profile format (version 1)::

    hid_profile: 1                  # format version (required)
    name: haptic_1dof               # optional; defaults to the file's stem
    description: ...                # optional, free text
    vendor_id: 0x1209               # USB ids (a device entry may override them)
    product_id: 0x0001
    max_force: 4.0                  # N; required with an output report; the device's bound: every
                                    #   force is clamped to it, a device entry may only lower it
                                    #   (finite, > 0, at most FORCE_CEILING = 1000 N, and what the field holds)
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
import os
import re

from ..blocks.device import Haptic
from ..graph.errors import PatchError
from ..graph.source import LDict, load_yaml
from .hid_reports import Field, InputReport, OutputReport, Profile
from .driver_kind import attached
from .limits import FORCE_CEILING
from .yaml_checks import Checker, is_int, line_of

SUFFIXES = (".yaml", ".yml")
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")   # used with fullmatch: a name is matched whole
# names no axis or button may take: the haptic block's own ports, settings and sensor columns, the
# time, and `estimate` (the velocity setting's value)
RESERVED = ("t", *(d.name for d in Haptic.outputs + Haptic.inputs), *Haptic.params,
            *(e.attr for e in Haptic.externals), "estimate")
MAX_REPORT = 4096        # bytes; USB full speed interrupt reports are ≤ 64, high speed ≤ 1024

TOP_KEYS = ("hid_profile", "name", "description", "vendor_id", "product_id", "max_force", "input", "output")
INPUT_KEYS = ("report_id", "length", "interval", "timeout", "position", "velocity", "velocity_cutoff",
              "axes", "buttons")
OUTPUT_KEYS = ("report_id", "length", "force")
AXIS_KEYS = ("byte", "bit", "size", "signed", "endian", "scale", "offset", "relative", "unit")
BUTTON_KEYS = ("byte", "bit")
FORCE_KEYS = ("byte", "bit", "size", "signed", "endian", "scale")

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
    profile = attached(spec, "hid_profile")
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


def check_field(chk, name, node, where, keys, default_size, length, line):
    """One field of a report (HID or serial profile); None if it has a problem (reported on `chk`)."""
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
        size = int(node["size"]) if is_int(node["size"]) else node["size"]
        if not is_int(size) or not 1 <= size <= 64:
            chk.add(line_of(node, "size"), f"{where}.size: {size!r} is not a size in bits from 1 to 64")
            size = None
    signed = chk.boolean(node, "signed", where)
    endian = chk.text(node, "endian", where, "little")
    if endian not in ("little", "big"):
        chk.add(line_of(node, "endian"), f"{where}.endian: {endian!r} is not little or big")
    scale = chk.number(node, "scale", where, 1.0, nonzero=True)
    offset = chk.number(node, "offset", where, 0.0)
    relative = chk.boolean(node, "relative", where)
    unit = chk.text(node, "unit", where)
    if size is not None and signed and size < 2:
        chk.add(line_of(node, "signed"), f"{where}: a signed field needs at least 2 bits")
    if endian == "big" and size is not None and bit is not None and (bit or size % 8):
        chk.add(line_of(node, "endian"), f"{where}: endian big needs whole bytes at bit 0 "
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


def check_overlaps(chk, fields, what):
    """Report (on `chk`) every field of `fields` whose bits overlap an earlier one's."""
    spans = sorted(fields, key=lambda f: (f.first_bit, f.line))
    for a, i in zip(spans, range(len(spans))):
        for b in spans[i + 1:]:
            if b.first_bit >= a.end_bit:
                break
            first, second = sorted((a, b), key=lambda f: f.line)
            chk.add(second.line, f"{what}: field {second.name!r} (bits {second.first_bit}…{second.end_bit - 1}) "
                                 f"overlaps {first.name!r} (bits {first.first_bit}…{first.end_bit - 1}, "
                                 f"line {first.line})")


def check_fields(chk, node, key, where, keys, default_size, length, names):
    """The fields of group `key` (axes, buttons) of a report mapping, each checked (check_field);
    `names`: the names taken so far (a name used twice is reported)."""
    group = node.get(key)
    if group is None:
        return []
    if not isinstance(group, LDict):
        chk.add(line_of(node, key), f"{where}.{key}: expected a mapping of name -> field")
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
        f = check_field(chk, name, spec, here, keys, default_size, length, line)
        if f is not None:
            out.append(f)
    return out


def _parse(doc, path, problems):
    chk = Checker(problems)
    if not isinstance(doc, LDict):
        chk.add(getattr(doc, "line", 1), "a HID profile is a mapping starting with `hid_profile: 1`")
        return None
    if doc.get("hid_profile") != 1:
        chk.add(line_of(doc, "hid_profile"), "the first key must be `hid_profile: 1` (the profile format version)"
                if "hid_profile" not in doc else f"unsupported HID profile version {doc['hid_profile']!r}; "
                                                 "this hapticgraph reads version 1")
    chk.keys(doc, TOP_KEYS, "profile")
    name = chk.text(doc, "name", "profile", os.path.splitext(os.path.basename(path))[0])
    description = chk.text(doc, "description", "profile")
    vid = chk.integer(doc, "vendor_id", "profile", 0, 0xFFFF, required=True)
    pid = chk.integer(doc, "product_id", "profile", 0, 0xFFFF, required=True)
    max_force = _max_force(chk, doc)
    inp = chk.mapping(doc, "input", "profile")
    report = _input_report(chk, inp) if inp is not None else None
    outp = chk.mapping(doc, "output", "profile", required=False)
    out = _output_report(chk, outp, doc, max_force) if outp is not None else None
    if not chk.ok or report is None:
        return None
    return Profile(name, path, vid, pid, report, out, max_force or 0.0, description)


def _max_force(chk, doc):
    max_force = chk.number(doc, "max_force", "profile", None, positive=True)
    if max_force is not None and max_force > FORCE_CEILING:
        chk.add(line_of(doc, "max_force"), f"profile.max_force: {max_force:g} N is above {FORCE_CEILING:g} N, "
                                           "the most any device may state")
        return None
    return max_force


def _input_report(chk, inp):
    """The `input:` mapping as an InputReport; None if it has a problem (reported)."""
    chk.keys(inp, INPUT_KEYS, "input")
    rid = chk.integer(inp, "report_id", "input", 0, 255, default=0)
    length = chk.integer(inp, "length", "input", 1, MAX_REPORT, required=True)
    interval = chk.number(inp, "interval", "input", None, required=True, positive=True)
    timeout = chk.number(inp, "timeout", "input", None, positive=True)
    if timeout is not None and interval is not None and timeout <= interval:
        chk.add(line_of(inp, "timeout"), f"input.timeout: {timeout:g} s must be longer than the report "
                                         f"interval {interval:g} s")
    cutoff = chk.number(inp, "velocity_cutoff", "input", 50.0, nonneg=True)
    names = {}
    axes = check_fields(chk, inp, "axes", "input", AXIS_KEYS, 8, length, names)
    buttons = check_fields(chk, inp, "buttons", "input", BUTTON_KEYS, 1, length, names)
    if not axes and not buttons and "axes" not in inp and "buttons" not in inp:
        chk.add(inp.line, "input: no axes and no buttons: the device would give nothing")
    check_overlaps(chk, axes + buttons, "input")
    position = chk.text(inp, "position", "input", None)
    velocity = chk.text(inp, "velocity", "input", "estimate")
    _motion_axes(chk, inp, axes, position, velocity)
    if not chk.ok:
        return None
    return InputReport(rid, length, interval, tuple(axes), tuple(buttons), timeout, position, velocity, cutoff)


def _motion_axes(chk, inp, axes, position, velocity):
    """`position` and `velocity` name declared axes (or velocity is `estimate`, from a position)."""
    axis_names = [f.name for f in axes]
    declared = set(inp.get("axes") or ()) if isinstance(inp.get("axes"), LDict) else set()
    for key, value in (("position", position), ("velocity", velocity)):
        if value is None or (key == "velocity" and value == "estimate"):
            continue
        if value not in declared:
            other = " or `estimate`" if key == "velocity" else ""
            chk.add(line_of(inp, key), f"input.{key}: no axis named {value!r} "
                                       f"(axes: {', '.join(axis_names) or 'none'}){other}")
    if velocity == "estimate" and position is None and "velocity" in inp:
        chk.add(line_of(inp, "velocity"), "input.velocity: `estimate` needs a `position` axis")


def _output_report(chk, outp, doc, max_force):
    """The `output:` mapping as an OutputReport; None if it has a problem (reported)."""
    chk.keys(outp, OUTPUT_KEYS, "output")
    rid = chk.integer(outp, "report_id", "output", 0, 255, default=0)
    length = chk.integer(outp, "length", "output", 1, MAX_REPORT, required=True)
    force_node = outp.get("force")
    force = None
    if force_node is None:
        chk.add(outp.line, "output: missing 'force' (the field that carries the force)")
    else:
        if isinstance(force_node, LDict):
            force_node.line = line_of(outp, "force")
        force = check_field(chk, "force", force_node, "output.force", FORCE_KEYS, 16, length, line_of(outp, "force"))
    if max_force is None and "max_force" not in doc:
        chk.add(outp.line, "profile: a device with a force output needs `max_force` [N], "
                           "the limit every force is clamped to")
    if force is not None and max_force is not None:
        lo, hi = force.limits()
        top = min(abs(lo / force.scale), abs(hi / force.scale)) if force.signed else abs(hi / force.scale)
        if max_force > top * (1 + 1e-9):
            chk.add(line_of(doc, "max_force"), f"max_force {max_force:g} N does not fit the output's force "
                                               f"field (at most {top:g} N with scale {force.scale:g})")
    if force is not None and chk.ok:
        return OutputReport(rid, length, force)
    return None


__all__ = ["check_field", "check_fields", "check_overlaps", "Field", "InputReport", "OutputReport", "Profile", "find_profile", "load_profile",
           "profile_of", "shipped_dir", "shipped_profiles"]
