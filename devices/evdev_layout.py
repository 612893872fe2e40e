"""A Linux input device (evdev) as a patch sees it: its inputs named the way a HID device's are
(hapticgraph.devices.hid_descriptor) and normalised by their absinfo, and finding the device a
`match:` names.

    wheel: {driver: evdev, match: {name: "G29"}}
    stick: {driver: evdev, match: {vendor: 0x045e, product: 0x001b}}
    two:   {driver: evdev, match: {name: "Extreme 3D", index: 1}}          # the second of two alike
    this:  {driver: evdev, match: {path: /dev/input/event7}}

Names. The kernel's HID driver maps HID usages onto evdev codes (drivers/hid/hid-input.c): X…RZ
onto ABS_X…ABS_RZ, a Slider onto ABS_THROTTLE, a Dial onto ABS_RUDDER, a Wheel or a Steering
onto ABS_WHEEL, Accelerator onto ABS_GAS, Brake onto ABS_BRAKE, a hat switch onto ABS_HAT0X and
ABS_HAT0Y. The ports are named from the codes: x, y, z, rx, ry, rz, throttle, rudder, wheel,
accelerator, brake, hat_x, hat_y (hat2_x … for ABS_HAT1X …), other ABS codes by their evdev name
less ABS_ (`abs_misc` → misc); `x` is the haptic block's x (the wheel's steering, the stick's
X), not a port. Keys are button1 … buttonN in the order of their key codes — for a HID
joystick, its HID button N (BTN_TRIGGER is button1).

Values. Centred axes (x, y, z, rx, ry, rz, wheel, rudder, and any whose absinfo range includes
negative values) give −1 … 1 from absinfo min … max; throttle, accelerator, brake and the rest
0 … 1; hats −1, 0 or 1 (right and down positive); buttons 0 or 1. Until an event comes, an axis
holds the value the kernel had when the device was opened.

python-evdev is imported only when a device is looked for (`evdev_module`; the tests replace it
with a stand-in of the same interface).
"""
from dataclasses import dataclass

from .errors import DeviceError

MATCH_KEYS = ("vendor", "product", "name", "serial", "path", "index")
EV_KEY, EV_ABS, EV_FF = 0x01, 0x03, 0x15     # linux/input-event-codes.h
FF_CONSTANT = 0x52
ABS_HAT0X, ABS_HAT3Y = 0x10, 0x17
ABS_NAMES = {0x00: "x", 0x01: "y", 0x02: "z", 0x03: "rx", 0x04: "ry", 0x05: "rz", 0x06: "throttle",
             0x07: "rudder", 0x08: "wheel", 0x09: "accelerator", 0x0A: "brake"}
CENTRED = {0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x07, 0x08}


class EvdevMatchError(DeviceError):
    """No input device matches, or it cannot do what the driver needs."""


def evdev_module():
    """python-evdev (PyPI `evdev`), or DeviceError naming the package to install."""
    try:
        import evdev
    except ImportError:
        raise DeviceError("the evdev driver needs python-evdev: pip install 'evdev>=1.7' (Linux only)") from None
    return evdev


def abs_name(code, names):
    """The port name of ABS code `code` (`names`: python-evdev's ecodes.ABS, code -> name)."""
    if code in ABS_NAMES:
        return ABS_NAMES[code]
    if ABS_HAT0X <= code <= ABS_HAT3Y:
        k, axis = divmod(code - ABS_HAT0X, 2)
        return f"hat{k + 1 if k else ''}_{'xy'[axis]}"
    name = names.get(code, f"abs_{code:#x}")
    name = name[0] if isinstance(name, (list, tuple)) else name
    return name.lower().removeprefix("abs_") or f"abs_{code:#x}"


@dataclass(frozen=True)
class Axis:
    """One ABS code: its port name, its absinfo range and how it is normalised."""

    code: int
    name: str
    minimum: int
    maximum: int
    scaling: str        # centred | positive | hat
    initial: int = 0    # its value when the device was read (absinfo's `value`)

    def value(self, raw):
        lo, hi = self.minimum, self.maximum
        if self.scaling == "hat":
            return float((raw > 0) - (raw < 0))
        if hi == lo:
            return 0.0
        raw = min(max(raw, lo), hi)
        if self.scaling == "positive":
            return (raw - lo) / (hi - lo)
        return 2.0 * (raw - lo) / (hi - lo) - 1.0


class EvdevLayout:
    """What a device's capabilities give a patch: `axes` (Axis, code order), `keys` (codes),
    `ports` (the haptic block's extra outputs: every name but x), `force_feedback` (the FF codes)
    and `constant_force`. `caps`: `capabilities(absinfo=True)`; `abs_names`: ecodes.ABS."""

    def __init__(self, caps, abs_names, name="", path="", vendor=0, product=0):
        self.name, self.path, self.vendor, self.product = name, path, vendor, product
        axes = []
        for code, info in sorted(caps.get(EV_ABS, ()), key=lambda item: item[0]):
            lo, hi = int(info.min), int(info.max)
            how = ("hat" if ABS_HAT0X <= code <= ABS_HAT3Y else
                   "centred" if code in CENTRED or lo < 0 else "positive")
            axes.append(Axis(code, abs_name(code, abs_names), lo, hi, how, int(info.value)))
        self.axes = tuple(axes)
        self.keys = tuple(sorted(caps.get(EV_KEY, ())))
        self.key_names = tuple(f"button{k + 1}" for k in range(len(self.keys)))
        self.position = next((a for a in self.axes if a.name == "x"), None)
        self.ports = tuple(a.name for a in self.axes if a is not self.position) + self.key_names
        self.force_feedback = tuple(caps.get(EV_FF, ()))
        self.constant_force = FF_CONSTANT in self.force_feedback


def _info(dev):
    info = dev.info
    return {"name": dev.name or "", "path": str(dev.path), "vendor": int(info.vendor), "product": int(info.product),
            "serial": dev.uniq or ""}


def _wanted(d, match):
    for key in ("vendor", "product", "path", "serial"):
        if key in match and d[key] != match[key]:
            return False
    return "name" not in match or str(match["name"]).lower() in d["name"].lower()


def describe_match(match):
    return "{" + ", ".join(f"{k}: 0x{match[k]:04x}" if k in ("vendor", "product") else f"{k}: {match[k]!r}"
                           for k in MATCH_KEYS if k in match) + "}"


def find(match, module=None):
    """(InputDevice, EvdevLayout) of the device `match` names, opened; EvdevMatchError if none
    matches. Devices are taken in the order of their paths (event0, event1, ...), so `index`
    tells two of one model apart as `serial` does."""
    evdev = module if module is not None else evdev_module()
    found, seen = [], []
    for path in sorted(evdev.list_devices(), key=_event_number):
        try:
            dev = evdev.InputDevice(path)
        except OSError:
            continue                   # a node this user may not open
        d = _info(dev)
        seen.append(f"{d['vendor']:04x}:{d['product']:04x} {d['name']!r} {d['path']}")
        if _wanted(d, match):
            found.append(dev)
        else:
            dev.close()
    index = int(match.get("index", 0))
    for k, dev in enumerate(found):
        if k != index:
            dev.close()
    if index >= len(found):
        which = f" (index {index}: {len(found)} match)" if found else ""
        raise EvdevMatchError(f"no input device matches {describe_match(match)}{which}; "
                              f"input devices: {'; '.join(seen) or 'none readable in /dev/input'}")
    dev = found[index]
    d = _info(dev)
    layout = EvdevLayout(dev.capabilities(absinfo=True), evdev.ecodes.ABS, d["name"], d["path"], d["vendor"],
                         d["product"])
    return dev, layout


def _event_number(path):
    tail = str(path).rsplit("event", 1)[-1]
    return (0, int(tail), str(path)) if tail.isdigit() else (1, 0, str(path))


def connected(module=None):
    """Every input device this user can open (`hapticgraph devices`): path, name, vendor,
    product, serial, `inputs` (port names, x first), `force_feedback` (its FF codes) and
    `constant_force`. Empty without python-evdev (not Linux)."""
    try:
        evdev = module if module is not None else evdev_module()
    except DeviceError:
        return []
    out = []
    for path in sorted(evdev.list_devices(), key=_event_number):
        try:
            dev = evdev.InputDevice(path)
        except OSError:
            continue
        try:
            d = _info(dev)
            layout = EvdevLayout(dev.capabilities(absinfo=True), evdev.ecodes.ABS)
        finally:
            dev.close()
        inputs = (["x"] if layout.position is not None else []) + list(layout.ports)
        out.append({**d, "inputs": inputs, "force_feedback": layout.force_feedback,
                    "constant_force": layout.constant_force})
    return out


def device_lines(devices):
    """`hapticgraph devices`' lines for the input devices `connected()` gives (those with axes)."""
    lines = []
    for d in devices:
        if not d["inputs"]:
            continue
        ff = "constant force (driver: evdev)" if d["constant_force"] else "yes, no constant force" \
            if d["force_feedback"] else "no"
        shown = ", ".join(d["inputs"][:24]) + (f", … ({len(d['inputs'])} in all)" if len(d["inputs"]) > 24 else "")
        lines.append(f"  {d['vendor']:04x}:{d['product']:04x}  {d['name']}  {d['path']}"
                     f"{'  serial ' + d['serial'] if d['serial'] else ''}")
        lines.append(f"      inputs: {shown}; force feedback: {ff}")
    return lines


def no_kernel_driver(hid_devices, input_devices):
    """One line for each HID PID force-feedback device (`hid_devices`: hid_match.connected()'s
    entries) the kernel gives no force feedback through evdev (`input_devices`: dicts with
    vendor, product and force_feedback): hid-pidff did not bind it."""
    ff = {(d["vendor"], d["product"]) for d in input_devices if d.get("force_feedback")}
    lines = []
    for d in hid_devices:
        ids = (d.get("vendor_id", 0), d.get("product_id", 0))
        if d.get("force_feedback") and ids not in ff:
            name = " ".join(x for x in (d.get("manufacturer_string"), d.get("product_string")) if x) or "HID device"
            lines.append(f"{name} ({ids[0]:04x}:{ids[1]:04x}) has HID PID force feedback but no kernel driver "
                         f"gives it through evdev (is hid-pidff loaded? a quirk for this id needed?)")
    return lines


__all__ = ["Axis", "EvdevLayout", "EvdevMatchError", "MATCH_KEYS", "abs_name", "connected", "describe_match",
           "device_lines", "evdev_module", "find", "no_kernel_driver"]
