"""`hapticgraph hid profile DEVICE_OR_FILE`: a HID profile (hapticgraph.devices.hid_profiles)
written from a report descriptor, commented, to edit: the names become the haptic block's
ports; ranges and scaling are the descriptor's, as `driver: hid` without a profile reads them.

A profile reads one input report, so the profile holds the report with the X axis (else the one
with most inputs); the others, array inputs (a profile has no arrays) and the force-feedback
reports are listed in comments. The X axis is named `x_axis` (`x` is the haptic block's own
port) and is the profile's `position`.
"""
import os
import re

from .hid_profiles import RESERVED
from .hid_usages import page_name

DEFAULT_INTERVAL = 0.008


def _number(v):
    return repr(float(v)) if not float(v).is_integer() else f"{float(v):.1f}"


def _scaling(i):
    """(offset, scale, comment) so that (counts − offset) × scale is the value the descriptor gives."""
    lo, hi = i.logical_min, i.logical_max
    span = hi - lo or 1
    if i.scaling == "physical":
        pspan = i.physical_max - i.physical_min
        offset = lo - i.physical_min * span / pspan
        return offset, pspan / span * i.factor, f"physical {i.physical_min}…{i.physical_max} -> {i.unit}"
    if i.scaling == "positive":
        return lo, 1.0 / span, "0 … 1"
    if i.signed:
        return 0.0, 1.0 / max(hi, -lo, 1), "−1 … 1"
    return (lo + hi) / 2.0, 2.0 / span, "−1 … 1"


def _name(i):
    name = "x_axis" if i.name == "x" else i.name
    if name in RESERVED:
        name = f"{name}_axis"
    return name


def _field(i, extra=""):
    byte, bit = divmod(i.bit_offset, 8)
    parts = [f"byte: {byte}"] + ([f"bit: {bit}"] if bit else []) + [f"size: {i.bit_size}"]
    if i.signed:
        parts.append("signed: true")
    return parts, f"{page_name(i.usage_page)} 0x{i.usage:02x}, logical {i.logical_min}…{i.logical_max}{extra}"


def _main_report(desc):
    usable = [i for i in desc.inputs if i.array_value is None]
    by_report = {}
    for i in usable:
        by_report.setdefault(i.report_id, []).append(i)
    if not by_report:
        return None, []
    rid = next((i.report_id for i in usable if i.name == "x"), None)
    if rid is None:
        rid = max(by_report, key=lambda r: len(by_report[r]))
    return rid, by_report[rid]


def _slug(text):
    return re.sub(r"[^a-z0-9]+", "_", str(text).lower()).strip("_") or "hid_device"


def profile_text(desc, source, title="", ids=None, name=None):
    """The profile's text (see the module's doc); `ids`: (vendor, product) when known."""
    rid, inputs = _main_report(desc)
    vendor, product = ids or (0, 0)
    lines = [f"# A HID profile written by `hapticgraph hid profile {source}`",
             f"# from {title or source}.",
             "# Edit it: the names are the haptic block's ports; SI value = (counts − offset) × scale.",
             "# `driver: hid, profile: THIS_FILE.yaml` then reads the device through it (format: docs/devices.md).",
             "hid_profile: 1",
             f"name: {_slug(name or os.path.splitext(os.path.basename(str(source)))[0])}",
             f"vendor_id: 0x{vendor:04x}" + ("" if ids else "       # not in the descriptor: set your device's"),
             f"product_id: 0x{product:04x}" + ("" if ids else "      # not in the descriptor: set your device's")]
    if rid is None:
        lines.append("# the descriptor has no input a profile can read (only arrays or nothing)")
        return "\n".join(lines) + "\n"
    axes = [i for i in inputs if not (i.kind == "button" and i.bit_size == 1)]
    buttons = [i for i in inputs if i.kind == "button" and i.bit_size == 1]
    position = next((i for i in axes if i.name == "x" and i.kind == "axis"), None)
    lines += ["input:",
              f"  report_id: {rid}" + ("" if rid else "          # the device numbers no reports"),
              f"  length: {desc.report_sizes[rid]}            # bytes of report data after the id byte",
              f"  interval: {DEFAULT_INTERVAL}       # s: the descriptor does not say; USB full speed polls at 125 Hz"]
    if position is not None:
        lines += ["  position: x_axis      # the haptic block's x", "  velocity: estimate", "  velocity_cutoff: 20"]
    lines += _axis_lines(axes)
    if buttons:
        lines.append("  buttons:")
    for i in buttons:
        byte, bit = divmod(i.bit_offset, 8)
        lines.append(f"    {_name(i)}: {{byte: {byte}, bit: {bit}}}   # {page_name(i.usage_page)} 0x{i.usage:02x}")
    left = [i for i in desc.inputs if i.report_id != rid or i.array_value is not None]
    if left:
        lines.append("# Not in this profile (a profile reads one report and has no arrays): "
                     + _listed(left))
    lines += _force_lines(desc)
    return "\n".join(lines) + "\n"


def _axis_lines(axes):
    """The profile's `axes:` lines, each with what it reads."""
    lines = []
    if axes:
        lines.append("  axes:")
    for i in axes:
        parts, what = _field(i)
        if i.kind == "hat":
            what += f" (hat: {i.logical_max - i.logical_min + 1} positions clockwise from up; outside: centred)"
        else:
            offset, scale, how = _scaling(i)
            if offset:
                parts.append(f"offset: {_number(offset)}")
            parts.append(f"scale: {scale!r}")
            what += f" -> {how}"
            if i.relative:
                parts.append("relative: true")
                what += " (a change: the profile sums it)"
        lines.append(f"    {_name(i)}: {{{', '.join(parts)}}}   # {what}")
    return lines


def _force_lines(desc):
    """Comment lines on the device's HID PID force reports (a profile cannot drive them)."""
    lines = []
    forces = [o for o in desc.outputs if o.usage_page == 0x0F]
    if forces:
        magnitude = next((o for o in forces if o.name == "constant_force_magnitude"), None)
        lines += ["# Force feedback: the device has HID PID output reports ("
                  + ", ".join(sorted({str(o.report_id) for o in forces}, key=int)) + "). A profile's `output` writes one",
                  "# field of one report; a PID device plays a force only once an effect is created and started, which",
                  "# a profile does not do. The constant force's magnitude, for reference:"]
        if magnitude is not None:
            byte, bit = divmod(magnitude.bit_offset, 8)
            lines += ["# max_force: 1.0        # N: every force is clamped to it",
                      "# output:",
                      f"#   report_id: {magnitude.report_id}",
                      f"#   length: {(magnitude.bit_offset + magnitude.bit_size + 7) // 8}",
                      f"#   force: {{byte: {byte}, size: {magnitude.bit_size}"
                      f"{', signed: true' if magnitude.logical_min < 0 else ''}, scale: {magnitude.logical_max}}}"
                      f"   # counts per newton if full scale were 1 N: set it from the device's rating"]
    return lines


def _listed(items):
    names = [i.name for i in items]
    text = ", ".join(names[:20])
    return text + (f", … ({len(names)} in all)" if len(names) > 20 else "")


__all__ = ["profile_text"]
