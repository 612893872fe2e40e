"""A HID report descriptor, parsed with hid-tools (hidtools.hid.ReportDescriptor), as the named
inputs and outputs a patch sees: `parse(data)` -> Descriptor.

Why hid-tools (hidtools.hid, with its usage tables hidtools.hut) and not hid-parser 0.1: on this
corpus (tests/data/hid) hid-parser loses what a player's device needs — it keeps no collections
(a joystick and a keyboard in one device cannot be told apart), drops units and exponents, raises
NotImplementedError on Push/Pop, and gives a Report Count larger than its usages only as many
fields as usages, so the FR-TEC Raptor's report (128 buttons, 29 usages) comes out 405 bits long
instead of 504 and every field after the buttons at the wrong offset; it has no usage names.
What hid-tools gets wrong is put right here: a one-byte Unit Exponent such as 0xFD (−3) it
reads as 237; a field with no usage (usage 0) is padding, as in the kernel; a field wider than
its all-ones Logical Maximum item (`25 FF` on a 16-bit field: −1 as HID 1.11 reads signed item
data, 255 as hid-tools and the kernel read it) spans its bits, 0 … 2^size − 1, as Windows reads
a maximum below the minimum — the case of the descriptors hidapi rebuilds from Windows' parse,
the Xbox controller's among them, whose sticks fill 16 bits (tests/devices/test_hid_descriptor.py).

Every non-constant input field with a usage becomes one Input (see hapticgraph.devices.hid_usages
for its name and scaling):
- `axis`: a variable field with more than two values; centred −1 … 1 or positive 0 … 1, or, when
  the descriptor gives a unit and a physical range, the physical value in SI units (m, kg, s, rad);
  relative fields (mice, 3-D mice) give their change, normalised, falling back to 0 when silent.
- `button`: a variable one-bit (two-valued) field, 0 or 1; or one usage of an array field
  (a keyboard's keys, buttons sent as a list): 1 while the usage is in the array.
- `hat`: Generic Desktop Hat switch, three ports: NAME_x and NAME_y (−1, 0 or 1: right and down
  positive, as HID's X and Y) and NAME (the angle in degrees clockwise from up, NaN when centred:
  a value outside the logical range is the null state).
Output fields are listed as Outputs (kind `output`); those on the PID page (HID PID force
feedback) make `force_feedback` true. Names repeated in one device are numbered in report order
(slider, slider2).

Bit offsets count from the first bit of the report's data, after the report-id byte of a
numbered report (as a profile's `byte`/`bit` do).
"""
import math
from dataclasses import dataclass, field, replace

from hidtools.hid import HidUnit, ParseError, ReportDescriptor, Unit

from .hid_usages import (BUTTON, GENERIC_DESKTOP, HAT_SWITCH, PID, application_label, page_name, scaling, slug,
                         table_name, usage_name)

MAX_ARRAY_BUTTONS = 256      # an array of more usages (a consumer-control list) gives no ports
# SI base for each unit hid-tools names: (symbol, factor to SI)
SI_UNITS = {Unit.CENTIMETER: ("m", 0.01), Unit.INCH: ("m", 0.0254), Unit.RADIANS: ("rad", 1.0),
            Unit.DEGREES: ("rad", math.pi / 180.0), Unit.GRAM: ("kg", 0.001), Unit.SLUG: ("kg", 14.5939029),
            Unit.SECONDS: ("s", 1.0), Unit.KELVIN: ("K", 1.0), Unit.AMPERE: ("A", 1.0), Unit.CANDELA: ("cd", 1.0)}


class DescriptorError(ValueError):
    """The bytes are not a report descriptor hid-tools can read."""


@dataclass(frozen=True)
class Input:
    """One named input of a device: where its bits are and how they become a value."""

    name: str
    kind: str                # axis | button | hat
    usage_page: int
    usage: int
    report_id: int           # 0: the device numbers no reports
    bit_offset: int
    bit_size: int
    logical_min: int
    logical_max: int
    physical_min: int = 0
    physical_max: int = 0
    unit: str = ""           # the SI unit of a physical value ("" : normalised)
    factor: float = 1.0      # SI per physical count (unit and exponent)
    scaling: str = "button"  # centred | positive | physical | button | hat
    signed: bool = False
    relative: bool = False
    null_state: bool = False
    array_value: int = None  # for a usage of an array field: the slot value that means it
    array_count: int = 1     # slots of that array (each bit_size wide, from bit_offset)
    application: str = ""    # the top-level collection it belongs to (joystick, gamepad, ...)
    collection: int = 0      # that collection's index in the descriptor (0, 1, ...)

    @property
    def ports(self):
        """The port names this input gives a patch."""
        return (f"{self.name}_x", f"{self.name}_y", self.name) if self.kind == "hat" else (self.name,)

    def as_dict(self):
        out = {"name": self.name, "kind": self.kind, "usage_page": self.usage_page, "usage": self.usage,
               "report_id": self.report_id, "bit_offset": self.bit_offset, "bit_size": self.bit_size,
               "logical_min": self.logical_min, "logical_max": self.logical_max,
               "physical_min": self.physical_min, "physical_max": self.physical_max, "unit": self.unit,
               "scaling": self.scaling, "signed": self.signed, "relative": self.relative,
               "null_state": self.null_state, "application": self.application, "collection": self.collection,
               "ports": list(self.ports)}
        if self.array_value is not None:
            out["array_value"], out["array_count"] = self.array_value, self.array_count
        return out


@dataclass(frozen=True)
class Output:
    """One field of an output report (a force-feedback parameter, a LED, a rumble motor)."""

    name: str
    usage_page: int
    usage: int
    report_id: int
    bit_offset: int
    bit_size: int
    count: int
    logical_min: int
    logical_max: int
    array: bool = False
    application: str = ""
    kind: str = "output"

    def as_dict(self):
        return {"name": self.name, "kind": self.kind, "usage_page": self.usage_page, "usage": self.usage,
                "report_id": self.report_id, "bit_offset": self.bit_offset, "bit_size": self.bit_size,
                "count": self.count, "logical_min": self.logical_min, "logical_max": self.logical_max,
                "array": self.array, "application": self.application}


@dataclass(frozen=True)
class Descriptor:
    """A parsed descriptor: its inputs (report order), outputs, report sizes and collections."""

    data: bytes
    inputs: tuple
    outputs: tuple
    numbered: bool                              # reports start with a report-id byte
    report_sizes: dict = field(default_factory=dict)   # input report id -> data bytes (after the id)
    applications: tuple = ()                    # (label, page, usage) of each top-level collection

    @property
    def force_feedback(self):
        return any(o.usage_page == PID for o in self.outputs)

    @property
    def ports(self):
        return tuple(p for i in self.inputs for p in i.ports)

    def read_size(self):
        """Bytes of the longest input report as hidapi returns it (the id byte included)."""
        return max(self.report_sizes.values(), default=1) + (1 if self.numbered else 0)


# -- parsing -----------------------------------------------------------------------------------

def _exponent(e):
    """hid-tools' Unit Exponent, taken back to the signed value the item holds (see the doc)."""
    if e > 127 and e + 16 < 256:
        return e + 16 - 256
    return e


def _unit(f):
    """(SI symbol, factor per physical count) of a field, or ("", 1.0) when it has no unit."""
    if not f.unit:
        return "", 1.0
    try:
        unit = HidUnit.from_value(f.unit)
    except (ValueError, AssertionError):
        return "", 1.0
    if unit is None:
        return "", 1.0
    parts, factor = [], 10.0 ** _exponent(f.unit_exp)
    for u, power in unit.units.items():
        if u not in SI_UNITS:
            return "", 1.0                 # Fahrenheit (not a scale), reserved
        symbol, scale = SI_UNITS[u]
        factor *= scale ** power
        parts.append(symbol if power == 1 else f"{symbol}^{power}")
    return " ".join(parts), factor


def _signed(f):
    return f.logical_min < 0


def _base(f, rid, offset, name, application, collection):
    return dict(name=name, usage_page=(f.usage >> 16) & 0xFFFF, usage=f.usage & 0xFFFF, report_id=rid,
                bit_offset=offset, bit_size=f.size, logical_min=f.logical_min, logical_max=f.logical_max,
                physical_min=f.physical_min, physical_max=f.physical_max, signed=_signed(f),
                relative=bool(f.type & 0x04), null_state=bool(f.type & 0x40), application=application,
                collection=collection)


def _variable_input(f, rid, offset, application, collection):
    page, usage = (f.usage >> 16) & 0xFFFF, f.usage & 0xFFFF
    base = _base(f, rid, offset, usage_name(page, usage), application, collection)
    if page == GENERIC_DESKTOP and usage == HAT_SWITCH:
        return Input(kind="hat", scaling="hat", **base)
    if f.logical_max - f.logical_min == 1 and not (f.type & 0x04):
        return Input(kind="button", scaling="button", **base)
    symbol, factor = _unit(f)
    if symbol and f.physical_max != f.physical_min:
        return Input(kind="axis", scaling="physical", unit=symbol, factor=factor, **base)
    return Input(kind="axis", scaling=scaling(page, usage, _signed(f)), **base)


def _array_inputs(f, rid, offset, application, collection):
    """One button per usage of an array field (a usage in any slot: pressed)."""
    usages = list(f.usages or ())
    if len(usages) > MAX_ARRAY_BUTTONS:
        return []
    out = []
    for k, u in enumerate(usages):
        page, usage = (u >> 16) & 0xFFFF, u & 0xFFFF
        if usage == 0 and page in (BUTTON, 0x07):       # "no button pressed", "no event"
            continue
        base = _base(f, rid, offset, usage_name(page, usage), application, collection)
        base.update(usage_page=page, usage=usage)
        out.append(Input(kind="button", scaling="button", array_value=f.logical_min + k,
                         array_count=f.count, **base))
    return out


def _output(f, rid, offset, application):
    page, usage = (f.usage >> 16) & 0xFFFF, f.usage & 0xFFFF
    name = usage_name(page, usage)
    if page == PID and f.logical:
        report = table_name(PID, f.logical & 0xFFFF) or ""
        prefix = slug(report.replace("Set ", "").replace(" Report", ""))
        if prefix and not name.startswith(prefix):
            name = f"{prefix}_{name}"
    return Output(name, page, usage, rid, offset, f.size, f.count, f.logical_min, f.logical_max,
                  array=not (f.type & 0x02), application=application)


def _number(items):
    """Number repeated names in order: slider, slider2, slider3 (button29, button29_2 after a digit);
    a name already taken (a reserved one, or slider2 given by a usage) is skipped over."""
    taken, counts, out = set(RESERVED_PORTS), {}, []
    for item in items:
        base = item.name
        n = counts.get(base, 0)
        name = base if n == 0 and base not in taken else None
        while name is None or name in taken:
            n += 1
            name = base if n == 1 else f"{base}_{n}" if base[-1].isdigit() else f"{base}{n}"
        counts[base] = n
        taken.add(name)
        if item.kind == "hat":
            taken.update((f"{name}_x", f"{name}_y"))
        out.append(item if name == item.name else replace(item, name=name))
    return out


# the haptic block's own ports and settings: no input may take these names (x is the X axis: the
# haptic block's x, see hapticgraph.devices.hid_layout)
RESERVED_PORTS = ("t", "v", "force", "device", "axes", "sensor_x", "sensor_v", "estimate")


def parse(data):
    """The Descriptor of report-descriptor bytes; DescriptorError if hid-tools cannot read them."""
    data = bytes(data)
    if not data:
        raise DescriptorError("the report descriptor is empty")
    try:
        rd = ReportDescriptor.from_bytes(list(data))
    except (ParseError, KeyError, IndexError, ValueError, AssertionError) as exc:
        raise DescriptorError(f"not a HID report descriptor hid-tools can read ({exc})") from None
    apps, inputs, outputs = _applications(rd), [], []
    wide = _wider_than_their_maximum(rd)
    numbered = any(rid >= 0 for rid in list(rd.input_reports) + list(rd.output_reports) + list(rd.feature_reports))
    sizes = {}
    for raw_rid, report in rd.input_reports.items():
        rid = max(raw_rid, 0)
        shift = 8 if report.numbered else 0
        sizes[rid] = (report.bitsize - shift + 7) // 8
        for f in report.fields:
            if f.is_const or (f.usage & 0xFFFFFFFF) == 0 and not f.usages:
                continue
            label, index = _application_of(f, apps)
            offset = f.start - shift
            if f.is_array:
                inputs += _array_inputs(f, rid, offset, label, index)
            elif (raw_rid, f.logical_min, f.logical_max, f.size) in wide:
                inputs.append(replace(_variable_input(f, rid, offset, label, index), logical_max=(1 << f.size) - 1))
            else:
                inputs.append(_variable_input(f, rid, offset, label, index))
    for rid, report in rd.output_reports.items():
        shift = 8 if report.numbered else 0
        for f in report.fields:
            if f.is_const or (f.usage & 0xFFFFFFFF) == 0:
                continue
            label, _ = _application_of(f, apps)
            outputs.append(_output(f, max(rid, 0), f.start - shift, label))
    return Descriptor(data, tuple(_number(inputs)), tuple(_number(outputs)), numbered, sizes,
                      tuple((label, page, usage) for label, page, usage in apps))


def _wider_than_their_maximum(rd):
    """{(report id, logical min, logical max, bit size)} of the Input items whose Logical Maximum item
    is all ones (0xFF, 0xFFFF: −1 read signed) and narrower than the field, the minimum not negative."""
    g, stack, out = {"rid": -1, "min": 0, "max": 0, "raw": (), "size": 0}, [], set()
    for item in rd.rdesc_items:
        if item.item == "Report ID":
            g["rid"] = item.value
        elif item.item == "Logical Minimum":
            g["min"] = item.value
        elif item.item == "Logical Maximum":
            g["max"], g["raw"] = item.value, tuple(item.raw_value)
        elif item.item == "Report Size":
            g["size"] = item.value
        elif item.item == "Push":
            stack.append(dict(g))
        elif item.item == "Pop" and stack:
            g = stack.pop()
        elif item.item == "Input" and g["raw"] and set(g["raw"]) == {0xFF} and g["min"] >= 0 \
                and g["size"] > 8 * len(g["raw"]):
            out.add((g["rid"], g["min"], g["max"], g["size"]))
    return out


def _applications(rd):
    """(label, page, usage) of the top-level collections, in the order their fields appear."""
    seen = []
    for reports in (rd.input_reports, rd.output_reports, rd.feature_reports):
        for report in reports.values():
            for f in report.fields:
                key = (f.collection[0] if f.collection else 0, f.application or 0)
                if key not in seen:
                    seen.append(key)
    seen.sort()
    return [(application_label((app >> 16) & 0xFFFF, app & 0xFFFF), (app >> 16) & 0xFFFF, app & 0xFFFF)
            for _, app in seen]


def _application_of(f, apps):
    app = f.application or 0
    page, usage = (app >> 16) & 0xFFFF, app & 0xFFFF
    for k, (label, p, u) in enumerate(apps):
        if (p, u) == (page, usage):
            return label, k
    return application_label(page, usage), 0


# -- as text ------------------------------------------------------------------------------------

def describe_lines(desc, title=None):
    """`hapticgraph hid describe`'s text: one line per input, then the outputs."""
    lines = [title] if title else []
    apps = ", ".join(label for label, _, _ in desc.applications) or "none"
    lines.append(f"collections: {apps}; reports {'numbered' if desc.numbered else 'not numbered'}; "
                 f"force feedback: {'yes (HID PID)' if desc.force_feedback else 'no'}")
    lines.append(f"inputs ({len(desc.inputs)}):")
    for i in desc.inputs:
        where = f"report {i.report_id} bits {i.bit_offset}+{i.bit_size}"
        if i.array_value is not None:
            where += f" (array of {i.array_count}, value {i.array_value})"
        rng = f"{i.logical_min}…{i.logical_max}"
        how = {"centred": "−1 … 1", "positive": "0 … 1", "button": "0/1",
               "hat": f"{i.name}_x, {i.name}_y −1…1, {i.name} degrees (NaN centred)",
               "physical": f"{i.physical_min * i.factor:g} … {i.physical_max * i.factor:g} {i.unit}"}[i.scaling]
        flags = "".join((" relative" if i.relative else "", " signed" if i.signed else ""))
        lines.append(f"  {i.name:16s} {i.kind:6s} {page_name(i.usage_page)} 0x{i.usage:02x}  {where}  "
                     f"logical {rng}{flags}  -> {how}")
    forces = [o for o in desc.outputs if o.usage_page == PID]
    others = [o for o in desc.outputs if o.usage_page != PID]
    for label, group in (("force outputs (HID PID)", forces), ("other outputs", others)):
        if group:
            lines.append(f"{label} ({len(group)}):")
            for o in group:
                lines.append(f"  {o.name:28s} report {o.report_id} bits {o.bit_offset}+{o.bit_size}"
                             f"{'x' + str(o.count) if o.count > 1 else ''}  logical {o.logical_min}…{o.logical_max}"
                             f"{'  array' if o.array else ''}")
    return lines


def as_json(desc):
    """`hapticgraph hid describe --json`: a list of objects, the inputs then the outputs."""
    return [i.as_dict() for i in desc.inputs] + [o.as_dict() for o in desc.outputs]


__all__ = ["Descriptor", "DescriptorError", "Input", "Output", "RESERVED_PORTS", "as_json", "describe_lines",
           "parse"]
