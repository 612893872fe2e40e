"""HID report descriptors (tests/data/hid: real devices' descriptors, sources in its README):
parsed with hid-tools and named from the usage tables, each checked against what the descriptor
says (bit offsets and sizes, logical ranges, report ids, collections); decoding of reports
built by hand into the values players expect; `hapticgraph hid describe [--json]` on the corpus
and on bad files (FILE:LINE, exit 2)."""
import json
import math
import pathlib

import numpy as np
import pytest

from hapticgraph.cli import main
from hapticgraph.devices.hid_descriptor import DescriptorError, parse
from hapticgraph.devices.hid_layout import DescribedDevice
from hapticgraph.devices.hid_recording import RecordingError, read_descriptor

CORPUS = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid"
FILES = sorted(p for p in CORPUS.iterdir() if p.suffix in (".rdesc", ".hid"))


def desc(name):
    return parse(read_descriptor(CORPUS / name)[0])


def field(d, name):
    found = [i for i in d.inputs + d.outputs if i.name == name]
    assert len(found) == 1, (name, [i.name for i in d.inputs])
    return found[0]


def spot(d, name):
    f = field(d, name)
    return (f.report_id, f.bit_offset, f.bit_size, f.logical_min, f.logical_max)


def test_the_corpus_is_there_and_every_file_parses():
    assert len(FILES) >= 20
    readme = (CORPUS / "README.md").read_text(encoding="utf-8")
    for path in FILES:
        assert path.name in readme, f"{path.name} has no source in tests/data/hid/README.md"
        d = parse(read_descriptor(path)[0])
        names = [p for i in d.inputs for p in i.ports]
        assert names or path.name == "logitech_receiver_consumer_046d_c52f.rdesc", path.name
        assert len(names) == len(set(names)), path.name


def test_an_array_of_more_usages_than_ports_are_worth_gives_none():
    d = desc("logitech_receiver_consumer_046d_c52f.rdesc")      # Usage Minimum 1, Maximum 0x28c, Input (Data,Arr)
    assert d.inputs == () and d.numbered and d.report_sizes == {3: 4}
    assert d.applications == (("consumer", 0x0C, 0x01),)


def test_an_array_of_buttons():
    d = desc("sony_ps3_bd_remote_054c_0306.rdesc")      # Usage Minimum (No button pressed), Maximum 254
    array = [i for i in d.inputs if i.array_value is not None]
    assert len(array) == 254 and array[0].name == "button1_2" and array[0].array_value == 1
    assert {(i.bit_offset, i.bit_size, i.array_count) for i in array} == {(32, 8, 1)}
    dev = DescribedDevice(d)
    r, _ = row_of(dev, bytes([0, 0b1, 0, 0, 0x0E]) + bytes(6) + bytes([3]))
    assert r["button1"] == 1 and r["button14_2"] == 1 and r["button13_2"] == 0
    assert r["battery_strength"] == pytest.approx(3 / 5)


# -- what each descriptor says -------------------------------------------------------------------

def test_wheel_with_a_14_bit_axis_spanning_bytes():
    d = desc("logitech_driving_force_pro_046d_c298.rdesc")     # Report Size (14), Logical Max (16383)
    assert not d.numbered and d.report_sizes == {0: 8}
    assert spot(d, "x") == (0, 0, 14, 0, 16383) and field(d, "x").scaling == "centred"
    assert [i.name for i in d.inputs if i.kind == "button"] == [f"button{k}" for k in range(1, 15)]
    assert spot(d, "button1")[1:3] == (14, 1) and spot(d, "button14")[1:3] == (27, 1)
    hat = field(d, "hat")
    assert (hat.kind, hat.bit_offset, hat.bit_size, hat.logical_max, hat.null_state) == ("hat", 28, 4, 7, True)
    assert spot(d, "y") == (0, 40, 8, 0, 255) and spot(d, "rz") == (0, 48, 8, 0, 255)   # a constant byte between
    assert not d.force_feedback and d.applications == (("joystick", 1, 4),)


def test_wheel_with_a_10_bit_axis_and_vendor_fields():
    d = desc("logitech_driving_force_046d_c294.rdesc")         # Report Size (10), Logical Max (1023)
    assert spot(d, "x") == (0, 0, 10, 0, 1023)
    assert spot(d, "vendor_ff00_0001") == (0, 22, 1, 0, 1) and spot(d, "vendor_ff00_0001_2") == (0, 23, 1, 0, 1)
    assert spot(d, "y") == (0, 40, 8, 0, 255) and spot(d, "rz") == (0, 48, 8, 0, 255)


def test_joystick_with_a_pid_force_feedback_section():
    d = desc("saitek_joystick_pid_06a3_ff0d.rdesc")
    assert d.numbered and d.force_feedback
    assert spot(d, "x") == (1, 0, 8, 0, 255) and spot(d, "y") == (1, 8, 8, 0, 255)
    assert spot(d, "rudder") == (1, 16, 8, 0, 255) and field(d, "rudder").scaling == "centred"
    assert spot(d, "throttle") == (1, 24, 8, 0, 255) and field(d, "throttle").scaling == "positive"
    assert spot(d, "button12") == (1, 43, 1, 0, 1)
    assert spot(d, "hat") == (1, 44, 4, 0, 7)
    # Set Constant Force Report (id 13): effect block index, then a signed magnitude
    assert spot(d, "constant_force_magnitude") == (13, 8, 8, -127, 127)
    assert field(d, "device_gain").report_id == 67
    assert all(o.kind == "output" for o in d.outputs)


def test_joystick_with_11_bit_axes_and_a_240_position_hat():
    d = desc("frtec_raptor_mach2_11c0_5606.rdesc")
    assert d.numbered and d.report_sizes == {1: 63}
    assert spot(d, "x") == (1, 0, 16, 0, 2047) and spot(d, "rx") == (1, 32, 16, 0, 1023)
    assert "usage_0000_0000" not in d.ports                        # the field with no usage: padding
    assert spot(d, "slider") == (1, 112, 16, 0, 1023) and field(d, "slider").scaling == "positive"
    assert spot(d, "hat") == (1, 256, 16, 0, 239)


def test_gamepad_with_two_top_level_collections():
    d = desc("asus_gamepad_18d1_2c40.rdesc")
    assert [a[0] for a in d.applications] == ["gamepad", "consumer"]
    assert [i.name for i in d.inputs][:11] == ["button1", "button2", "button4", "button5", "button7", "button8",
                                               "button14", "button15", "button13", "ac_back", "ac_home"]
    assert spot(d, "brake") == (1, 48, 8, 0, 255) and spot(d, "accelerator") == (1, 56, 8, 0, 255)
    battery = field(d, "battery_strength")
    assert (battery.report_id, battery.application, battery.collection) == (3, "consumer", 1)
    assert field(d, "x").collection == 0


@pytest.mark.parametrize("name, x_offset", [("sony_ps3_controller_054c_0268.rdesc", 40),
                                            ("sony_ps4_controller_usb_054c_05c4.rdesc", 0),
                                            ("sony_ps5_controller_usb_054c_0ce6.rdesc", 0)])
def test_sony_pads(name, x_offset):
    d = desc(name)
    assert spot(d, "x") == (1, x_offset, 8, 0, 255) and spot(d, "y")[1] == x_offset + 8


# -- decoding ----------------------------------------------------------------------------------

def row_of(device, report):
    dec = device.decoder()
    out = np.zeros(dec.width)
    assert dec.decode(bytes(report), out)
    return dict(zip(("x", "v") + device.ports, out.tolist())), dec


def test_decode_the_14_bit_wheel():
    dev = DescribedDevice(desc("logitech_driving_force_pro_046d_c298.rdesc"))
    # x = 16383 (14 bits), buttons 1 and 14, hat 8 (null: centred), a constant byte, y 0, rz 255
    word = 16383 | (1 << 14) | (1 << 27) | (8 << 28) | (0 << 40) | (255 << 48)
    r, _ = row_of(dev, word.to_bytes(8, "little"))
    assert r["x"] == 1.0 and r["y"] == -1.0 and r["rz"] == 1.0
    assert r["button1"] == 1 and r["button2"] == 0 and r["button14"] == 1
    assert (r["hat_x"], r["hat_y"]) == (0, 0) and math.isnan(r["hat"])
    word = 8191 | (2 << 28) | (128 << 40)
    r, _ = row_of(dev, word.to_bytes(8, "little"))
    assert r["x"] == pytest.approx(2 * 8191 / 16383 - 1) and r["y"] == pytest.approx(1 / 255)
    assert (r["hat_x"], r["hat_y"], r["hat"]) == (1, 0, 90.0)                       # right


def test_decode_the_240_position_hat_and_report_ids():
    dev = DescribedDevice(desc("frtec_raptor_mach2_11c0_5606.rdesc"))
    data = bytearray(63)
    data[0:2] = (2047).to_bytes(2, "little")          # x full right
    data[14:16] = (1023).to_bytes(2, "little")        # slider full
    data[16] = 0b101                                  # buttons 1 and 3
    data[32:34] = (30).to_bytes(2, "little")          # hat 30 of 0…239: 45°, up-right
    r, dec = row_of(dev, b"\x01" + bytes(data))
    assert r["x"] == 1.0 and r["slider"] == 1.0 and r["y"] == -1.0
    assert (r["button1"], r["button2"], r["button3"]) == (1, 0, 1)
    assert (r["hat_x"], r["hat_y"], r["hat"]) == (1, -1, 45.0)
    data[32:34] = (240).to_bytes(2, "little")         # beyond the logical maximum: the null state
    r, _ = row_of(dev, b"\x01" + bytes(data))
    assert (r["hat_x"], r["hat_y"]) == (0, 0) and math.isnan(r["hat"])
    out = np.zeros(dec.width)
    assert not dec.decode(b"\x58" + bytes(63), out)   # an output report's id: not an input
    assert not dec.decode(b"\x01" + bytes(10), out)   # too short


def test_only_one_collection_and_the_haptic_x():
    d = desc("asus_gamepad_18d1_2c40.rdesc")
    pad = DescribedDevice(d, collection=0)
    assert "battery_strength" not in pad.ports and "x" not in pad.ports and pad.position.name == "x"
    consumer = DescribedDevice(d, collection=1)
    assert consumer.position is None and consumer.ports[0] == "battery_strength"


# -- files and the command line ----------------------------------------------------------------

def test_descriptor_file_forms(tmp_path):
    data, _ = read_descriptor(CORPUS / "logitech_momo_force_046d_c295.rdesc")
    raw = tmp_path / "momo.bin"
    raw.write_bytes(data)
    c_array = tmp_path / "momo.h"
    c_array.write_text("/* Momo */\n" + "\n".join(f"0x{b:02X},  // item" for b in data) + "\n", encoding="utf-8")
    rec = tmp_path / "momo.hid"
    rec.write_text(f"# a recording\nD: 0\nR: {len(data)} {data.hex(' ')}\nN: Momo\nI: 3 046d c295\n", encoding="utf-8")
    for path in (raw, c_array, rec):
        assert read_descriptor(path)[0] == data, path


@pytest.mark.parametrize("text, message", [
    ("05 01\n09 0g\n", "F:2: '0g' is not a byte in hex"),
    ("", "F: the file is empty"),
    ("# nothing\n", "F: no bytes: expected a report descriptor (raw, hex, or a recording's R: line)"),
    ("D: 0\nR: 3 05 01\n", "F:2: R: the length says 3 bytes, the line has 2"),
    ("00 05 01\n", "F: not a HID report descriptor hid-tools can read (Unexpected HID type 0 in 00)"),
])
def test_describe_bad_files(tmp_path, capsys, text, message):
    path = tmp_path / "bad.rdesc"
    path.write_text(text, encoding="utf-8")
    assert main(["hid", "describe", str(path)]) == 2
    err = capsys.readouterr().err.strip().replace(str(path), "F")
    assert err == message and "Traceback" not in err


def test_describe_missing_file(capsys):
    assert main(["hid", "describe", "/nonexistent/stick.hid"]) == 2
    assert capsys.readouterr().err.startswith("/nonexistent/stick.hid: cannot read")


def test_describe_text(capsys):
    assert main(["hid", "describe", str(CORPUS / "saitek_joystick_pid_06a3_ff0d.rdesc")]) == 0
    out = capsys.readouterr().out
    assert "force feedback: yes (HID PID)" in out and "force outputs (HID PID)" in out
    assert any(line.split()[:2] == ["throttle", "axis"] for line in out.splitlines())


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_describe_json_on_the_corpus(path, capsys):
    assert main(["hid", "describe", str(path), "--json"]) == 0
    items = json.loads(capsys.readouterr().out)
    keys = {"name", "usage_page", "usage", "report_id", "bit_offset", "bit_size", "logical_min", "logical_max", "kind"}
    assert all(keys <= set(i) for i in items)
    assert {i["kind"] for i in items} <= {"axis", "button", "hat", "output"}
    d = parse(read_descriptor(path)[0])
    assert [i["name"] for i in items] == [i.name for i in d.inputs] + [o.name for o in d.outputs]


def test_parse_rejects_nothing():
    with pytest.raises(DescriptorError):
        parse(b"")
    with pytest.raises(RecordingError):
        read_descriptor("/nonexistent")


def test_yoke_lists_y_before_x_and_16_bit_axes():
    d = desc("thrustmaster_tca_yoke_boeing_044f_0409.rdesc")     # Usage (Y), Usage (X), ... Report Size (16)
    assert spot(d, "hat") == (1, 0, 4, 0, 7) and spot(d, "button18") == (1, 21, 1, 0, 1)
    assert spot(d, "y") == (1, 24, 16, 0, 65535) and spot(d, "x") == (1, 40, 16, 0, 65535)
    assert spot(d, "rz") == (1, 104, 16, 0, 65535)
    assert spot(d, "vendor_fff0_0051") == (1, 128, 8, 0, 255)
    assert spot(d, "vendor_fff0_0051_32")[1] == 128 + 31 * 8      # Report Count (32) of one usage


# A descriptor written for this test (not a device's): signed fields and physical units, the
# exponents in both encodings a device may use (0x0E for −2 as a nibble, 0xFD for −3 as a byte).
UNITS = bytes.fromhex(
    "05 01 09 04 a1 01"
    " 09 30 16 18 fc 26 e8 03 35 ce 45 32 65 11 55 0e 75 10 95 01 81 02"    # X: −1000…1000 -> −50…50 × 10⁻² cm
    " 09 32 15 00 26 e8 03 35 00 46 e8 03 65 11 55 fd 75 10 95 01 81 02"    # Z: 0…1000 -> 0…1000 × 10⁻³ cm
    " 09 31 15 81 25 7f 35 00 45 00 65 00 55 00 75 08 95 01 81 02"          # Y: −127…127, no unit
    " c0")


def test_physical_units_and_signed_fields():
    d = parse(UNITS)
    x, z, y = d.inputs
    assert (x.scaling, x.unit, x.signed) == ("physical", "m", True) and x.factor == pytest.approx(1e-4)
    assert (z.scaling, z.unit) == ("physical", "m") and z.factor == pytest.approx(1e-5)
    assert (y.scaling, y.signed, y.logical_min) == ("centred", True, -127)
    dev = DescribedDevice(d)
    report = (500).to_bytes(2, "little", signed=True) + (250).to_bytes(2, "little") + (-64).to_bytes(1, "little", signed=True)
    r, _ = row_of(dev, report)
    assert r["x"] == pytest.approx((-50 + 1500 * 100 / 2000) * 1e-4)       # 2.5 mm
    assert r["z"] == pytest.approx(250 * 1e-5) and r["y"] == pytest.approx(-64 / 127)
    r, _ = row_of(dev, (-1000).to_bytes(2, "little", signed=True) + bytes(2) + (127).to_bytes(1, "little"))
    assert r["x"] == pytest.approx(-50e-4) and r["y"] == 1.0


def test_3d_mouse_relative_axes_in_physical_units():
    d = desc("3dconnexion_spacenavigator_046d_c626.rdesc")   # Logical ±350, Physical ±1400, Unit cm, Exponent −4
    assert d.applications == (("multi_axis", 1, 8),)
    x = field(d, "x")
    assert spot(d, "x") == (1, 0, 16, -350, 350) and spot(d, "rz") == (2, 32, 16, -350, 350)
    assert (x.relative, x.signed, x.physical_min, x.physical_max, x.unit) == (True, True, -1400, 1400, "m")
    assert x.factor == pytest.approx(1e-6)
    dev = DescribedDevice(d)
    r, dec = row_of(dev, b"\x01" + (350).to_bytes(2, "little", signed=True) + (-175).to_bytes(2, "little", signed=True)
                    + bytes(2))
    assert r["x"] == pytest.approx(1.4e-3) and r["y"] == pytest.approx(-0.7e-3) and r["z"] == 0
    out = np.zeros(dec.width)
    assert dec.still(out) and out[0] == 0.0 and out[2] == 0.0      # silent: a relative field falls back to 0


def test_the_xbox_sticks_span_their_16_bits():
    """microsoft_xbox_controller_045e_02ff.rdesc (hidapi's rebuild of what Windows parsed) gives
    its 16-bit sticks and trigger axis `Logical Maximum (0xFF)` in one byte: −1 as HID 1.11 reads
    item data (signed), 255 as hid-tools and the kernel read it (unsigned when the minimum is not
    negative). Neither fits: the controller's reports fill the 16 bits — its own descriptors say
    0 … 65535 (the Xbox Wireless Controller's over Bluetooth: `27 FF FF 00 00`), xpad gives
    −32768 … 32767 — and Windows reads a maximum below the minimum as no bound. So a field wider
    than an all-ones Logical Maximum item spans its bits; read 0 … 255, a stick at rest (0x8000)
    would be pinned at +1."""
    d = desc("microsoft_xbox_controller_045e_02ff.rdesc")
    for name, offset in (("x", 0), ("y", 16), ("rx", 32), ("ry", 48), ("z", 64)):
        assert spot(d, name) == (0, offset, 16, 0, 65535), name
    dev = DescribedDevice(d)
    # x at 0, y at 0xffff, rx at rest 0x8000, ry 0x4000, z (both triggers) at rest 0x8000; hat 1 (up)
    fields = (0x0000, 0xFFFF, 0x8000, 0x4000, 0x8000)
    report = b"".join(v.to_bytes(2, "little") for v in fields) + bytes([0, 0, 1, 0, 0, 0])
    r, _ = row_of(dev, report)
    assert (r["x"], r["y"]) == (-1.0, 1.0)
    assert r["rx"] == pytest.approx(1 / 65535) and r["z"] == pytest.approx(1 / 65535)
    assert r["ry"] == pytest.approx(2 * 0x4000 / 65535 - 1)
    assert r["hat"] == 0.0 and spot(d, "hat") == (0, 96, 4, 1, 8)


@pytest.mark.parametrize("maximum, size, want", [
    ("25 ff", 8, 255),          # one byte on an 8-bit field: the kernel's 255 is the field's range too
    ("26 ff 00", 16, 255),      # two bytes, not all ones: 255 as written
    ("26 ff ff", 16, 65535),    # two bytes of ones on a 16-bit field
    ("25 ff", 16, 65535),       # one byte of ones on a 16-bit field (the Xbox's)
    ("26 ff ff", 32, 0xFFFFFFFF),
])
def test_an_all_ones_maximum_narrower_than_its_field(maximum, size, want):
    data = bytes.fromhex(f"05 01 09 04 a1 01 09 30 15 00 {maximum} 75 {size:02x} 95 01 81 02 c0")
    assert spot(parse(data), "x") == (0, 0, size, 0, want)
