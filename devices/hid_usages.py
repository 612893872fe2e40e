"""Names for HID usages: the port name a patch gives each input of a device read from its report
descriptor (hapticgraph.devices.hid_descriptor), and how its value is scaled.

Names come from the HID Usage Tables as hid-tools ships them (hidtools.hut.HUT), lower-cased,
with a few short forms players know:

    Generic Desktop      X, Y, Z, Rx, Ry, Rz, Slider, Dial, Wheel, Hat switch
                         -> x, y, z, rx, ry, rz, slider, dial, wheel, hat; others as the
                         tables say (D-pad Up -> dpad_up)
    Simulation Controls  throttle, rudder, accelerator, brake, steering, clutch, ...
    Button               button1 … buttonN (the usage id)
    Keyboard/Keypad      key_a, key_return, key_leftcontrol, keypad_1, ...
    Physical Interface   (HID PID, page 0x0F, which hid-tools has no table for: the names of the
    Device               PID 1.0 specification) magnitude, effect_type, device_gain, ...
    vendor pages         vendor_PAGE_USAGE in hex (vendor_ff00_0001)
    anything else        the tables' name, or usage_PAGE_USAGE in hex

Scaling (`scaling(page, usage, signed)`): `centred` (−1 … 1: sticks, steering, rudder, and any
signed axis), `positive` (0 … 1: throttles, pedals, sliders, and other unsigned axes).
"""
import re

from hidtools.hut import HUT

GENERIC_DESKTOP, SIMULATION, KEYBOARD, BUTTON, CONSUMER, PID = 0x01, 0x02, 0x07, 0x09, 0x0C, 0x0F
HAT_SWITCH = 0x39
VENDOR_PAGES = range(0xFF00, 0x10000)

DESKTOP_NAMES = {0x30: "x", 0x31: "y", 0x32: "z", 0x33: "rx", 0x34: "ry", 0x35: "rz", 0x36: "slider",
                 0x37: "dial", 0x38: "wheel", 0x39: "hat"}

# (page, usage) of axes that rest in the middle of their travel; every other unsigned axis rests
# at one end (a throttle, a pedal, a slider: 0 … 1)
CENTRED = {(GENERIC_DESKTOP, u) for u in (0x30, 0x31, 0x32, 0x33, 0x34, 0x35, 0x37, 0x38, 0x40, 0x41,
                                          0x42, 0x43, 0x44, 0x45)}
CENTRED |= {(SIMULATION, u) for u in (0xB0, 0xB8, 0xBA, 0xC8)}   # aileron, elevator, rudder, steering

# The Physical Interface Device page (HID PID 1.0, section 5): hid-tools has no table for it.
PID_NAMES = {
    0x01: "Physical Interface Device", 0x20: "Normal", 0x21: "Set Effect Report", 0x22: "Effect Block Index",
    0x23: "Parameter Block Offset", 0x24: "ROM Flag", 0x25: "Effect Type", 0x26: "ET Constant Force",
    0x27: "ET Ramp", 0x28: "ET Custom Force Data", 0x30: "ET Square", 0x31: "ET Sine", 0x32: "ET Triangle",
    0x33: "ET Sawtooth Up", 0x34: "ET Sawtooth Down", 0x40: "ET Spring", 0x41: "ET Damper", 0x42: "ET Inertia",
    0x43: "ET Friction", 0x50: "Duration", 0x51: "Sample Period", 0x52: "Gain", 0x53: "Trigger Button",
    0x54: "Trigger Repeat Interval", 0x55: "Axes Enable", 0x56: "Direction Enable", 0x57: "Direction",
    0x58: "Type Specific Block Offset", 0x59: "Block Type", 0x5A: "Set Envelope Report", 0x5B: "Attack Level",
    0x5C: "Attack Time", 0x5D: "Fade Level", 0x5E: "Fade Time", 0x5F: "Set Condition Report", 0x60: "CP Offset",
    0x61: "Positive Coefficient", 0x62: "Negative Coefficient", 0x63: "Positive Saturation",
    0x64: "Negative Saturation", 0x65: "Dead Band", 0x66: "Download Force Sample",
    0x67: "Isoch Custom Force Enable", 0x68: "Custom Force Data Report", 0x69: "Custom Force Data",
    0x6A: "Custom Force Vendor Defined Data", 0x6B: "Set Custom Force Report", 0x6C: "Custom Force Data Offset",
    0x6D: "Sample Count", 0x6E: "Set Periodic Report", 0x6F: "Offset", 0x70: "Magnitude", 0x71: "Phase",
    0x72: "Period", 0x73: "Set Constant Force Report", 0x74: "Set Ramp Force Report", 0x75: "Ramp Start",
    0x76: "Ramp End", 0x77: "Effect Operation Report", 0x78: "Effect Operation", 0x79: "Op Effect Start",
    0x7A: "Op Effect Start Solo", 0x7B: "Op Effect Stop", 0x7C: "Loop Count", 0x7D: "Device Gain Report",
    0x7E: "Device Gain", 0x7F: "PID Pool Report", 0x80: "RAM Pool Size", 0x81: "ROM Pool Size",
    0x82: "ROM Effect Block Count", 0x83: "Simultaneous Effects Max", 0x84: "Pool Alignment",
    0x85: "PID Pool Move Report", 0x86: "Move Source", 0x87: "Move Destination", 0x88: "Move Length",
    0x89: "PID Block Load Report", 0x8B: "Block Load Status", 0x8C: "Block Load Success",
    0x8D: "Block Load Full", 0x8E: "Block Load Error", 0x8F: "Block Handle", 0x90: "PID Block Free Report",
    0x91: "Type Specific Block Handle", 0x92: "PID State Report", 0x94: "Effect Playing",
    0x95: "PID Device Control Report", 0x96: "PID Device Control", 0x97: "DC Enable Actuators",
    0x98: "DC Disable Actuators", 0x99: "DC Stop All Effects", 0x9A: "DC Device Reset", 0x9B: "DC Device Pause",
    0x9C: "DC Device Continue", 0x9F: "Device Paused", 0xA0: "Actuators Enabled", 0xA4: "Safety Switch",
    0xA5: "Actuator Override Switch", 0xA6: "Actuator Power", 0xA7: "Start Delay", 0xA8: "Parameter Block Size",
    0xA9: "Device Managed Pool", 0xAA: "Shared Parameter Blocks", 0xAB: "Create New Effect Report",
    0xAC: "RAM Pool Available"}

# application collections a patch may name in `match: {usage: ...}`
APPLICATIONS = {"pointer": (GENERIC_DESKTOP, 0x01), "mouse": (GENERIC_DESKTOP, 0x02),
                "joystick": (GENERIC_DESKTOP, 0x04), "gamepad": (GENERIC_DESKTOP, 0x05),
                "keyboard": (GENERIC_DESKTOP, 0x06), "keypad": (GENERIC_DESKTOP, 0x07),
                "multi_axis": (GENERIC_DESKTOP, 0x08), "consumer": (CONSUMER, 0x01)}


def slug(text):
    """`D-pad Up` -> `dpad_up`: lower case, words joined by `_`, brackets dropped."""
    text = re.sub(r"\(.*?\)", "", str(text)).replace("-", "")
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def table_name(page, usage):
    """The usage's name in the HID Usage Tables (hid-tools', and PID's), or None."""
    if page == PID:
        return PID_NAMES.get(usage)
    try:
        return str(HUT[page][usage].name)
    except KeyError:
        return None


def page_name(page):
    if page == PID:
        return "Physical Interface Device"
    if page in VENDOR_PAGES:
        return f"Vendor 0x{page:04x}"
    try:
        return str(HUT[page].page_name)
    except KeyError:
        return f"Page 0x{page:04x}"


def usage_name(page, usage):
    """The port name of usage `usage` of page `page` (see the module's doc)."""
    if page in VENDOR_PAGES:
        return f"vendor_{page:04x}_{usage:04x}"
    if page == GENERIC_DESKTOP and usage in DESKTOP_NAMES:
        return DESKTOP_NAMES[usage]
    if page == BUTTON:
        return f"button{usage}"
    name = table_name(page, usage)
    if page == KEYBOARD:
        if name is None:
            return f"key_{usage:02x}"
        keypad = name.startswith("Keypad ")
        word = slug(re.sub(r"^(Keyboard|Keypad) ", "", name).split(" and ")[0])
        return f"{'keypad' if keypad else 'key'}_{word or f'{usage:02x}'}"
    text = slug(name) if name else ""
    if not text or not re.match(r"[a-z_]", text):
        return f"usage_{page:04x}_{usage:04x}"
    return text


def scaling(page, usage, signed):
    """`centred` (−1 … 1) or `positive` (0 … 1) for an axis of this usage."""
    return "centred" if signed or (page, usage) in CENTRED else "positive"


def application_usage(name):
    """(page, usage) of an application collection a patch names (`joystick`, or `0x01:0x04`), or None."""
    text = str(name).strip().lower()
    if text in APPLICATIONS:
        return APPLICATIONS[text]
    m = re.fullmatch(r"(0x[0-9a-f]+|\d+):(0x[0-9a-f]+|\d+)", text)
    return (int(m.group(1), 0), int(m.group(2), 0)) if m else None


def application_label(page, usage):
    """The name a patch uses for an application collection (`joystick`), else PAGE:USAGE in hex."""
    for label, key in APPLICATIONS.items():
        if key == (page, usage):
            return label
    return f"0x{page:02x}:0x{usage:02x}"


__all__ = ["APPLICATIONS", "BUTTON", "CENTRED", "CONSUMER", "GENERIC_DESKTOP", "HAT_SWITCH", "KEYBOARD", "PID",
           "SIMULATION", "VENDOR_PAGES", "application_label", "application_usage", "page_name", "scaling", "slug",
           "table_name", "usage_name"]
