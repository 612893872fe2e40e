"""Finding a connected HID device by what a patch says of it, and reading its report descriptor
through hidapi (`get_report_descriptor`; on Linux, if hidapi cannot, the hidraw node's
/sys/class/hidraw/hidrawN/device/report_descriptor):

    stick: {driver: hid, match: {vendor: 0x045e, product: 0x001b}}
    stick: {driver: hid, match: {name: "SideWinder"}}          # in the product (or maker) name
    stick: {driver: hid, match: {usage: joystick, index: 1}}    # the second joystick

`match` keys: `vendor`, `product` (USB ids), `name` (a part of the name, any case), `serial`,
`usage` (a top-level collection: joystick, gamepad, mouse, keyboard, multi_axis, consumer, or
PAGE:USAGE such as 0x01:0x04) and `index` (which of the devices that match, 0 the first, in
hidapi's order). With `usage`, a device with several top-level collections (a joystick and a
keyboard) gives the inputs of the matching collection only.

`connected()` is what `hapticgraph devices` shows: every device hidapi sees, with its usable
inputs and whether it has force feedback (read from its descriptor).
"""
import os
import re
from dataclasses import dataclass

from . import hid_transports
from .errors import DeviceError
from .hid_descriptor import DescriptorError, parse
from .hid_usages import application_label, application_usage

MATCH_KEYS = ("vendor", "product", "name", "serial", "usage", "index")
SYSFS_HIDRAW = "/sys/class/hidraw"       # Linux: where a hidraw node's descriptor is, if hidapi cannot say


class MatchError(DeviceError):
    """No connected device matches, or its descriptor cannot be read."""


@dataclass(frozen=True)
class Found:
    """A connected device a match chose: its hidapi entry, descriptor and collection (or None)."""

    info: dict
    descriptor: object          # a Descriptor
    collection: int = None

    @property
    def path(self):
        return self.info.get("path")

    @property
    def name(self):
        return " ".join(x for x in (self.info.get("manufacturer_string"), self.info.get("product_string")) if x)


def _text(value):
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else value


def _entries():
    """hidapi's enumerate(), one entry per device path (Linux lists a path once per collection)."""
    hid = hid_transports.hid_module()
    out, seen = [], set()
    for info in hid.enumerate():
        entry = {k: _text(v) for k, v in dict(info).items()}
        if entry.get("path") in seen:
            continue
        seen.add(entry.get("path"))
        out.append(entry)
    return out


def connected_entry(path):
    """hidapi's entry of the device at `path`, or None."""
    return next((e for e in _entries() if e.get("path") == path), None)


def _sysfs_descriptor(path):
    """Linux: the descriptor the kernel keeps for a hidraw node (/dev/hidrawN ->
    SYSFS_HIDRAW/hidrawN/device/report_descriptor), or None."""
    name = os.path.basename(str(path))
    if not re.fullmatch(r"hidraw\d+", name):
        return None
    try:
        with open(os.path.join(SYSFS_HIDRAW, name, "device", "report_descriptor"), "rb") as f:
            return f.read() or None
    except OSError:
        return None


def read_descriptor(path):
    """The report descriptor bytes of the device at hidapi path `path`: hidapi's
    get_report_descriptor, else (Linux) the hidraw node's in sysfs; MatchError if neither."""
    hid = hid_transports.hid_module()
    dev = hid.device()
    try:
        dev.open_path(path.encode() if isinstance(path, str) else path)
        try:
            return bytes(dev.get_report_descriptor())
        finally:
            dev.close()
    except (OSError, ValueError) as exc:
        data = _sysfs_descriptor(path)
        if data is not None:
            return data
        raise MatchError(f"cannot read the report descriptor of the HID device at {path}: {exc}") from None


def _wanted(entry, match):
    if "vendor" in match and entry.get("vendor_id") != match["vendor"]:
        return False
    if "product" in match and entry.get("product_id") != match["product"]:
        return False
    if "serial" in match and (entry.get("serial_number") or "") != str(match["serial"]):
        return False
    if "name" in match:
        name = f"{entry.get('manufacturer_string') or ''} {entry.get('product_string') or ''}".lower()
        if str(match["name"]).lower() not in name:
            return False
    return True


def describe_match(match):
    parts = []
    for key in MATCH_KEYS:
        if key in match:
            v = match[key]
            parts.append(f"{key}: 0x{v:04x}" if key in ("vendor", "product") and isinstance(v, int) else f"{key}: {v!r}")
    return "{" + ", ".join(parts) + "}"


def find(match):
    """The Found device `match` names (see the module's doc); MatchError if there is none."""
    usage = None
    if "usage" in match:
        usage = application_usage(match["usage"])
        if usage is None:
            raise MatchError(f"match usage {match['usage']!r} is not a collection (joystick, gamepad, mouse, "
                             f"keyboard, multi_axis, consumer, or PAGE:USAGE such as 0x01:0x04)")
    entries = _entries()
    candidates = []
    for entry in entries:
        if not _wanted(entry, match):
            continue
        if usage is None:
            candidates.append((entry, None))
            continue
        desc = _parse(entry)
        for k, (_, page, u) in enumerate(desc.applications):
            if (page, u) == usage:
                candidates.append((entry, (desc, k)))
    index = int(match.get("index", 0))
    if index >= len(candidates):
        seen = "; ".join(f"{e.get('vendor_id', 0):04x}:{e.get('product_id', 0):04x} "
                         f"{e.get('product_string') or '?'}" for e in entries) or "none"
        which = f" (index {index}: {len(candidates)} match)" if candidates else ""
        raise MatchError(f"no connected HID device matches {describe_match(match)}{which}; connected: {seen}")
    entry, chosen = candidates[index]
    if chosen is None:
        return Found(entry, _parse(entry))
    return Found(entry, chosen[0], chosen[1])


def _parse(entry):
    try:
        return parse(read_descriptor(entry["path"]))
    except DescriptorError as exc:
        raise MatchError(f"the HID device at {entry['path']}: {exc}") from None


def connected():
    """Every device hidapi sees (hapticgraph.devices.hid_transports.list_hid_devices: its ids,
    path, names and the shipped profile with its ids), one entry per path, with `inputs` (its
    port names), `collections` and `force_feedback` read from its descriptor, or
    `descriptor_error` when the descriptor cannot be read (a device another program holds)."""
    out, seen = [], set()
    for entry in hid_transports.list_hid_devices():
        if entry.get("path") in seen:
            continue
        seen.add(entry.get("path"))
        try:
            desc = _parse(entry)
        except MatchError as exc:
            out.append({**entry, "inputs": [], "collections": [], "force_feedback": False,
                        "descriptor_error": str(exc)})
            continue
        out.append({**entry, "inputs": list(desc.ports), "force_feedback": desc.force_feedback,
                    "collections": [application_label(p, u) for _, p, u in desc.applications]})
    return out


def device_lines(devices):
    """`hapticgraph devices`' lines for the HID devices `connected()` gives."""
    lines = []
    for d in devices:
        name = " ".join(x for x in (d.get("manufacturer_string"), d.get("product_string")) if x) or "?"
        extra = f"  profile {d['profile']}" if d.get("profile") else ""
        lines.append(f"  {d.get('vendor_id', 0):04x}:{d.get('product_id', 0):04x}  {name}  {d.get('path', '')}{extra}")
        if d.get("descriptor_error"):
            lines.append(f"      inputs: unknown ({d['descriptor_error']})")
            continue
        inputs = d["inputs"]
        shown = ", ".join(inputs[:24]) + (f", … ({len(inputs)} in all)" if len(inputs) > 24 else "")
        lines.append(f"      {', '.join(d['collections']) or 'no collection'}; inputs: {shown or 'none'}; "
                     f"force feedback: {'yes (HID PID)' if d['force_feedback'] else 'no'}")
    return lines


__all__ = ["Found", "MATCH_KEYS", "MatchError", "connected", "connected_entry", "describe_match", "device_lines", "find",
           "read_descriptor"]
