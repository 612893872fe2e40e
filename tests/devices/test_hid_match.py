"""`{driver: hid, match: {...}}`: connected devices found by ids, name or collection through hidapi
— a stand-in with hidapi's interface (tests/devices/hidapi_standin.py) fed by real recorded
descriptors and reports — named from their own descriptors; a live run reads the recorded
reports in real time; `hapticgraph devices`' lines; no match is a patch error (exit 2); real
hidapi (no device on this machine) finds nothing."""
import pathlib
import time

import numpy as np
import pytest

from hapticgraph import load
from hapticgraph.cli import main
from hapticgraph.devices import hid_match, hid_transports, open_drivers
from hapticgraph.devices.hid import HidDriver
from hapticgraph.devices.hid_match import MatchError, connected, device_lines, find
from hapticgraph.graph.errors import PatchError
from hidapi_standin import FakeDevice, FakeHidapi

CORPUS = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid"


def rdesc(name):
    return bytes.fromhex((CORPUS / name).read_text(encoding="utf-8"))


@pytest.fixture
def devices(monkeypatch):
    """Four devices: the PS3 pad playing its recording, two joysticks and a two-collection pad."""
    fake = FakeHidapi([
        FakeDevice.from_recording(CORPUS / "sony_ps3_controller_054c_0268.hid", b"/dev/hidraw0"),
        FakeDevice(b"/dev/hidraw1", 0x06A3, 0xFF0D, rdesc("saitek_joystick_pid_06a3_ff0d.rdesc"),
                   product="Saitek Cyborg Force", manufacturer="Saitek"),
        FakeDevice(b"/dev/hidraw2", 0x11C0, 0x5606, rdesc("frtec_raptor_mach2_11c0_5606.rdesc"),
                   product="FR-TEC Raptor MACH 2", manufacturer="Sanmos Group"),
        FakeDevice(b"/dev/hidraw3", 0x18D1, 0x2C40, rdesc("asus_gamepad_18d1_2c40.rdesc"), product="ASUS Gamepad"),
    ])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: fake)
    return fake


@pytest.mark.parametrize("match, path, collection", [
    ({"vendor": 0x054C, "product": 0x0268}, "/dev/hidraw0", None),
    ({"name": "raptor"}, "/dev/hidraw2", None),
    ({"name": "SAITEK"}, "/dev/hidraw1", None),
    ({"usage": "joystick"}, "/dev/hidraw0", 0),              # the PS3 pad's collection is a joystick
    ({"usage": "joystick", "index": 1}, "/dev/hidraw1", 0),
    ({"usage": "joystick", "index": 2}, "/dev/hidraw2", 0),
    ({"usage": "gamepad"}, "/dev/hidraw3", 0),
    ({"usage": "consumer"}, "/dev/hidraw3", 1),
    ({"usage": "0x01:0x05"}, "/dev/hidraw3", 0),
    ({"vendor": 0x18D1, "usage": "consumer"}, "/dev/hidraw3", 1),
])
def test_find(devices, match, path, collection):
    found = find(match)
    assert found.path == path and found.collection == collection


@pytest.mark.parametrize("match, message", [
    ({"vendor": 0x045E, "product": 0x001B}, "no connected HID device matches {vendor: 0x045e, product: 0x001b}; "
                                            "connected: 054c:0268 PLAYSTATION(R)3 Controller; 06a3:ff0d Saitek Cyborg "
                                            "Force; 11c0:5606 FR-TEC Raptor MACH 2; 18d1:2c40 ASUS Gamepad"),
    ({"usage": "joystick", "index": 3}, "(index 3: 3 match)"),
    ({"usage": "steering wheel"}, "match usage 'steering wheel' is not a collection"),
])
def test_no_match(devices, match, message):
    with pytest.raises(MatchError, match=message.replace("(", r"\(").replace(")", r"\)")):
        find(match)


PATCH = """
hapticgraph: 1
rate: 1000
devices:
  stick: {driver: hid, match: %s}
blocks:
  pick: {type: haptic, device: stick}
  g: {type: gain}
connect:
  - pick.x -> g.in
"""


def test_a_patch_names_a_device_by_its_ids_and_gets_its_ports(devices, write_patch):
    patch = load(write_patch(PATCH % "{vendor: 0x06a3, product: 0xff0d}"))
    ports = [p.name for p in patch.blocks["pick"].outputs]
    assert ports[:6] == ["x", "v", "y", "rudder", "throttle", "button1"]
    assert "hat_x" in ports and "hat" in ports and "effect_playing" in ports


def test_a_collection_of_a_device_with_two(devices, write_patch):
    patch = load(write_patch(PATCH.replace("  - pick.x -> g.in\n", "  - pick.battery_strength -> g.in\n")
                             % "{usage: consumer}"))
    assert [p.name for p in patch.blocks["pick"].outputs][2:] == ["battery_strength", "vendor_ffbc_bdad",
                                                                  "vendor_ffbc_bdad2", "vendor_ffbc_bdad3",
                                                                  "vendor_ffbc_bdad4", "vendor_ffbc_bdad5",
                                                                  "vendor_ffbc_bdad6"]


def test_no_device_is_a_patch_error_at_its_line(devices, write_patch, capsys):
    path = write_patch(PATCH % "{name: SideWinder}")
    with pytest.raises(PatchError) as info:
        load(path)
    assert [str(p) for p in info.value.problems][0].startswith(
        f"{path}:4: device 'stick': no connected HID device matches {{name: 'SideWinder'}}; connected: 054c:0268")
    assert main(["check", str(path)]) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_a_live_device_plays_its_reports(devices, write_patch):
    patch = load(write_patch(PATCH % "{vendor: 0x054c}"))
    drivers = open_drivers(patch, notes=[])
    driver = drivers["stick"]
    assert isinstance(driver, HidDriver) and not driver.stamped and devices.opened[-1] == b"/dev/hidraw0"
    driver.start(1000)
    try:
        ext = np.zeros((16, len(driver.columns)))
        deadline = time.monotonic() + 5
        while driver.w < 3 and time.monotonic() < deadline:       # the first three reports, within 7 ms
            time.sleep(0.005)
        driver.fill(0, ext)
        col = {c: k for k, c in enumerate(driver.columns)}
        np.testing.assert_allclose(ext[:, 0], 2 * 0x8D / 255 - 1)           # x: the haptic block's sensor
        np.testing.assert_allclose(ext[:, col["z"]], 2 * 0x81 / 255 - 1)
        driver.send(0, np.array([5.0]))                                       # no force output: nothing sent
    finally:
        driver.stop()
    assert devices.devices[0].written == [] and driver.max_force == 0.0 and driver.last_force == 0.0


def test_devices_listing(devices):
    listed = connected()
    assert [d["path"] for d in listed] == ["/dev/hidraw0", "/dev/hidraw1", "/dev/hidraw2", "/dev/hidraw3"]
    saitek = listed[1]
    assert saitek["force_feedback"] and saitek["collections"] == ["joystick"] and saitek["inputs"][:2] == ["x", "y"]
    lines = device_lines(listed)
    assert lines[2] == "  06a3:ff0d  Saitek Saitek Cyborg Force  /dev/hidraw1"
    assert lines[3].startswith("      joystick; inputs: x, y, rudder, throttle, button1") and \
        lines[3].endswith("force feedback: yes (HID PID)")
    assert lines[7].startswith("      gamepad, consumer; inputs: button1")


def test_the_devices_command_lists_each_device_with_its_inputs_and_force_feedback(devices, capsys):
    from hapticgraph.cli import main
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    hid = out[out.index("HID devices"):].splitlines()
    assert "  06a3:ff0d  Saitek Saitek Cyborg Force  /dev/hidraw1" in hid
    assert any(line.startswith("      joystick; inputs: x, y, rudder, throttle") and
               line.endswith("force feedback: yes (HID PID)") for line in hid), hid


def test_real_hidapi_finds_nothing_here():
    if hid_transports.list_hid_devices():
        pytest.skip("a HID device is connected")
    with pytest.raises(MatchError, match="connected: none"):
        find({"usage": "joystick"})
    assert connected() == []


def test_linux_sysfs_descriptor_when_hidapi_cannot(monkeypatch, tmp_path):
    class NoDescriptor(FakeHidapi):
        def device(self):
            handle = super().device()

            def refuse():
                raise OSError("get_report_descriptor failed")
            handle.get_report_descriptor = refuse
            return handle

    data = rdesc("logitech_driving_force_pro_046d_c298.rdesc")
    fake = NoDescriptor([FakeDevice(b"/dev/hidraw7", 0x046D, 0xC298, b"", product="Driving Force Pro")])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: fake)
    node = tmp_path / "hidraw7" / "device"
    node.mkdir(parents=True)
    (node / "report_descriptor").write_bytes(data)
    monkeypatch.setattr(hid_match, "SYSFS_HIDRAW", str(tmp_path))
    found = find({"name": "driving force"})
    assert found.descriptor.data == data and "x" in found.descriptor.ports
    monkeypatch.setattr(hid_match, "SYSFS_HIDRAW", str(tmp_path / "none"))
    with pytest.raises(MatchError, match="cannot read the report descriptor of the HID device at /dev/hidraw7"):
        find({"name": "driving force"})
