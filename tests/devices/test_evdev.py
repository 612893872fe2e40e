"""`driver: evdev`: force-feedback wheels and joysticks through the kernel (python-evdev), against a
stand-in with python-evdev's interface (tests/devices/evdev_standin.py) that records every call:
the sequence (gain, autocentre off, upload, play … zero, stop, erase, autocentre back, close),
the levels clamped to max_force × 0x7fff and slew-limited, zero before anything else on a stop,
the inputs named and normalised as a HID device's, and the signal paths in child processes
(SIGTERM: zero then erase; SIGKILL: the device's fd closes with the process, which is what makes
the kernel erase its effects)."""
import json
import math
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from evdev import ecodes

import hapticgraph
from hapticgraph.devices import evdev_layout, hid_transports
from hapticgraph.devices.errors import DeviceError
from hapticgraph.devices.evdev_ff import FULL, MAX_RATE, SLEW, EvdevDriver, slew
from hapticgraph.devices.evdev_kind import EvdevKind
from hapticgraph.devices.evdev_layout import EvdevLayout, connected, device_lines, find, no_kernel_driver
from hapticgraph.devices.table import driver_kinds
from hapticgraph.graph.engine import SafetyStop
from hapticgraph.graph.errors import PatchError

import hidapi_standin
from evdev_standin import FakeDevice, FakeEvdev

HERE = os.path.dirname(os.path.abspath(__file__))
RATE = 44100
WRITE, UPLOAD = "write", "upload"


def kinds():
    return {**driver_kinds(), "evdev": EvdevKind()}


@pytest.fixture
def wheel(monkeypatch):
    dev = FakeDevice.wheel()
    fake = FakeEvdev([FakeDevice.stick(), dev])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: fake)
    return dev


def patch_file(tmp_path, force, entry="{driver: evdev, match: {name: G29}, max_force: 0.4}", extra=""):
    path = tmp_path / "wheel.yaml"
    path.write_text(textwrap.dedent(f"""\
        hapticgraph: 1
        name: wheel
        rate: {RATE}
        devices:
          wheel: {entry}
        blocks:
          push: {{type: constant, value: {force}}}
          w: {{type: haptic, device: wheel}}
          out: {{type: audio_out, channels: 1}}
        connect:
          - push.out -> w.force
          - w.x -> out.ch0
        {extra}"""))
    return path


def run(path, blocks, blocksize=64, probes=()):
    patch = hapticgraph.load(str(path), drivers=kinds())
    with hapticgraph.Session.open(patch, blocksize=blocksize, probes=probes) as s:
        out = [s.process(blocksize).copy() for _ in range(blocks)]
        driver = s.drivers["wheel"]
    return driver, out


# -- the thin path: one wheel, the constant force follows the patch ---------------------------------

def test_the_wheel_plays_the_patch_force_with_the_exact_call_sequence(wheel, tmp_path):
    driver, _ = run(patch_file(tmp_path, 0.3), blocks=40)
    calls = wheel.ff_calls() + [("close",)]             # the handles opened only to read the device closed
    assert wheel.calls[-1] == ("close",)
    assert calls[:4] == [(WRITE, ecodes.EV_FF, ecodes.FF_GAIN, 0xFFFF), (WRITE, ecodes.EV_FF, ecodes.FF_AUTOCENTER, 0),
                         (UPLOAD, 0, 0xC000, 0), (WRITE, ecodes.EV_FF, 0, 1)]
    levels = wheel.levels()
    step = SLEW * 64 / RATE * FULL
    rising = levels[1:levels.index(round(0.3 * FULL))]
    assert len(rising) >= 5 and all(0 < b - a <= step + 1 for a, b in zip([0] + rising, rising))
    assert levels[-2] == round(0.3 * FULL)             # held at the patch's force (0.3 of full scale)
    assert calls[-5:] == [(UPLOAD, 0, 0xC000, 0), (WRITE, ecodes.EV_FF, 0, 0), ("erase", 0),
                          (WRITE, ecodes.EV_FF, ecodes.FF_AUTOCENTER, 0xFFFF), ("close",)]
    assert driver.last_force == pytest.approx(0.3)


def test_a_force_beyond_max_force_is_clamped_to_max_force_of_full_scale(wheel, tmp_path):
    run(patch_file(tmp_path, -5.0), blocks=60)
    levels = wheel.levels()
    assert min(levels) == -round(0.4 * FULL) and max(levels) == 0
    assert [c[2] for c in wheel.calls if c[0] == UPLOAD and c[3]] == [0x4000] * sum(1 for v in levels if v)


def test_slew_limit():
    assert slew(0.0, 0.5, 0.1) == pytest.approx(0.1)
    assert slew(0.45, 0.5, 0.1) == pytest.approx(0.5)
    assert slew(0.5, 0.1, 0.1) == 0.1                  # a fall is at once
    assert slew(0.5, -0.5, 0.1) == pytest.approx(-0.1)  # a change of side goes through zero
    assert slew(0.3, 0.0, 0.01) == 0.0


def opened_driver(dev, spec=None, rate=RATE):
    fake = FakeEvdev([dev])
    device, layout = find({"path": dev.path}, fake)
    driver = EvdevDriver("wheel", spec or {"max_force": 0.5}, device, layout, fake)
    driver.start(rate)
    return driver


def test_nan_and_a_fault_zero_at_once_and_a_stop_zeroes_before_anything_else():
    dev = FakeDevice.wheel()
    d = opened_driver(dev)
    n = 441                                             # 100 blocks a second: every block may write
    for k in range(20):
        d.send(k * n, np.full(n, 0.5))
    assert dev.levels()[-1] == round(0.5 * FULL)
    d.send(20 * n, np.array([0.5, np.nan]))             # the newest sample is NaN: zero, at once
    assert dev.levels()[-1] == 0
    d.send(21 * n, np.full(n, 0.5))
    d.send(22 * n, np.zeros(n))                         # the engine's zeros after a blow-up
    assert dev.levels()[-1] == 0
    d.send(23 * n, np.full(n, 0.5))
    before = len(dev.calls)
    d.stop()
    assert dev.calls[before] == (UPLOAD, 0, 0xC000, 0)
    assert [c[0] for c in dev.calls[before:]] == [UPLOAD, WRITE, "erase", WRITE, "close"]


def test_levels_are_written_at_most_at_max_rate():
    dev = FakeDevice.wheel()
    d = opened_driver(dev, {"max_force": 1.0, "slew": 1000.0})
    n = 8                                               # 5512 blocks a second
    for k in range(551):                                # 0.1 s
        d.send(k * n, np.full(n, 0.2 + 0.1 * math.sin(k)))
    uploads = len(dev.levels()) - 1
    assert 0.1 * MAX_RATE * 0.8 <= uploads <= 0.1 * MAX_RATE + 1
    d.stop()


# blocks of 10 ms: a quarter of 250 ms is played again every 7th block (70 ms), of 100 ms every 3rd
@pytest.mark.parametrize("watchdog, plays", [(None, 1 + 100 // 7), (0.1, 1 + 100 // 3), (0, 1)])
def test_the_effect_ends_by_itself_unless_played_again(watchdog, plays):
    dev = FakeDevice.wheel()
    d = opened_driver(dev, {"max_force": 0.5} if watchdog is None else {"max_force": 0.5, "watchdog": watchdog})
    n = 441
    for k in range(100):                                # one second of a steady force
        d.send(k * n, np.full(n, 0.3))
    assert dev.replay_length == round(1000 * (0.25 if watchdog is None else watchdog))
    assert dev.calls.count((WRITE, ecodes.EV_FF, 0, 1)) == plays       # played again every quarter of it
    d.stop()


def test_inputs_are_named_as_hid_and_normalised_by_absinfo(wheel, tmp_path):
    patch = hapticgraph.load(str(patch_file(tmp_path, 0.0)), drivers=kinds())
    assert patch.blocks["w"].values["axes"] == ["y", "z", "rz", "hat_x", "hat_y"] + [f"button{k}" for k in range(1, 26)]
    stick = EvdevLayout(FakeEvdev([FakeDevice.stick()]).InputDevice("/dev/input/event5").capabilities(), ecodes.ABS)
    assert stick.ports == ("y", "rz", "throttle", "hat_x", "hat_y") + tuple(f"button{k}" for k in range(1, 9))
    assert stick.constant_force
    with hapticgraph.Session.open(patch, blocksize=64, probes=["w.x", "w.button3", "w.hat_x", "w.rz", "w.y"]) as s:
        first = s.probes_of(s.process(64))
        assert first["w.y"][0] == 1.0 and abs(first["w.x"][0]) < 1e-4      # absinfo's values until events come
        wheel.feed(ecodes.EV_ABS, ecodes.ABS_X, 65535)
        wheel.feed(ecodes.EV_KEY, ecodes.BTN_TRIGGER + 2, 1)
        wheel.feed(ecodes.EV_ABS, ecodes.ABS_HAT0X, -1)
        wheel.feed(ecodes.EV_ABS, ecodes.ABS_RZ, 0)
        time.sleep(0.2)
        probes = s.probes_of(s.process(64))
    assert probes["w.x"][-1] == 1.0 and probes["w.button3"][-1] == 1.0 and probes["w.hat_x"][-1] == -1.0
    assert probes["w.rz"][-1] == -1.0                  # rz is centred, as in the HID naming


def test_unplugged_mid_play_stops_the_run_naming_it(wheel, tmp_path):
    patch = hapticgraph.load(str(patch_file(tmp_path, 0.3)), drivers=kinds())
    with hapticgraph.Session.open(patch, blocksize=64) as s:
        for _ in range(10):
            s.process(64)
        wheel.unplug()
        time.sleep(0.2)
        with pytest.raises(SafetyStop, match="device 'wheel' stopped answering: read failed"):
            s.process(64)


def test_a_device_without_constant_force(monkeypatch, tmp_path):
    dev = FakeDevice.stick(effects=[])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: FakeEvdev([dev]))
    entry = "{driver: evdev, match: {name: SideWinder}}"
    patch = hapticgraph.load(str(patch_file(tmp_path, 0.3, entry=entry)), drivers=kinds())
    with hapticgraph.Session.open(patch, blocksize=64) as s:
        s.process(64)
    assert dev.ff_calls() == [] and dev.calls                 # inputs only: no effect, no gain
    entry = "{driver: evdev, match: {name: SideWinder}, max_force: 0.3}"
    patch = hapticgraph.load(str(patch_file(tmp_path, 0.3, entry=entry)), drivers=kinds())
    with pytest.raises(DeviceError, match="has no constant-force effect"):
        hapticgraph.Session.open(patch, blocksize=64)


def test_match_errors_are_patch_errors_at_the_line_and_index_picks_the_second(monkeypatch, tmp_path):
    one, two = FakeDevice.stick("/dev/input/event5", uniq="A1"), FakeDevice.stick("/dev/input/event11", uniq="B2")
    fake = FakeEvdev([two, one])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: fake)
    assert find({"name": "sidewinder", "index": 1}, fake)[1].path == "/dev/input/event11"   # event order, not listing
    assert find({"serial": "A1"}, fake)[1].path == "/dev/input/event5"
    path = patch_file(tmp_path, 0.1, entry="{driver: evdev, match: {name: G29}}")
    with pytest.raises(PatchError) as err:
        hapticgraph.load(str(path), drivers=kinds())
    assert str(err.value).count("no input device matches {name: 'G29'}") == 1
    assert ":5:" in str(err.value) and "045e:001b 'Microsoft SideWinder Force Feedback 2 Joystick'" in str(err.value)
    path = patch_file(tmp_path, 0.1, entry="{driver: evdev, match: {name: SideWinder}, max_force: 2.0}")
    with pytest.raises(PatchError, match="max_force"):
        hapticgraph.load(str(path), drivers=kinds())


def test_connected_devices_for_hapticgraph_devices():
    fake = FakeEvdev([FakeDevice.wheel(uniq="W1"), FakeDevice.stick(effects=[])])
    found = connected(fake)
    assert [(d["path"], d["constant_force"]) for d in found] == [("/dev/input/event3", True), ("/dev/input/event5", False)]
    assert found[1]["inputs"][:6] == ["x", "y", "rz", "throttle", "hat_x", "hat_y"]
    lines = device_lines(found)
    assert lines[0] == "  046d:c24f  Logitech G29 Driving Force Racing Wheel  /dev/input/event3  serial W1"
    assert lines[1].endswith("force feedback: constant force (driver: evdev)") and lines[3].endswith("feedback: no")
    assert all(c == ("close",) for d in fake.devices.values() for c in d.calls)       # opened, read, closed
    # the SideWinder's HID PID reports with no evdev force feedback: one line naming it
    hid = [{"vendor_id": 0x045E, "product_id": 0x001B, "product_string": "SideWinder Force Feedback 2 Joystick",
            "force_feedback": True}]
    assert len(no_kernel_driver(hid, found)) == 1 and no_kernel_driver(hid, found)[0].startswith("SideWinder Force")


def test_a_match_for_a_hid_pid_device_the_kernel_does_not_drive_says_so(monkeypatch, tmp_path):
    rdesc = os.path.join(HERE, "..", "data", "hid", "saitek_joystick_pid_06a3_ff0d.rdesc")
    with open(rdesc, encoding="utf-8") as f:
        descriptor = bytes.fromhex(f.read())
    hid = hidapi_standin.FakeHidapi([hidapi_standin.FakeDevice(b"/dev/hidraw1", 0x06A3, 0xFF0D, descriptor,
                                                               product="Cyborg Force", manufacturer="Saitek")])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: hid)
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: FakeEvdev([FakeDevice.wheel()]))
    path = patch_file(tmp_path, 0.1, entry="{driver: evdev, match: {name: cyborg}}")
    with pytest.raises(PatchError) as err:
        hapticgraph.load(str(path), drivers=kinds())
    assert str(err.value).count("\n") <= 1 and (
        "no input device matches {name: 'cyborg'}; input devices: 046d:c24f 'Logitech G29 Driving Force Racing Wheel' "
        "/dev/input/event3; Saitek Cyborg Force (06a3:ff0d) has HID PID force feedback but no kernel driver gives "
        "it through evdev") in str(err.value)


def test_a_hid_pid_device_the_kernel_does_not_drive_is_said_in_one_line():
    hid = [{"vendor_id": 0x045E, "product_id": 0x001B, "manufacturer_string": "Microsoft",
            "product_string": "SideWinder Force Feedback 2 Joystick", "force_feedback": True},
           {"vendor_id": 0x046D, "product_id": 0xC24F, "product_string": "G29", "force_feedback": True},
           {"vendor_id": 0x054C, "product_id": 0x0268, "product_string": "PS3", "force_feedback": False}]
    lines = no_kernel_driver(hid, [{"vendor": 0x046D, "product": 0xC24F, "force_feedback": (0x52,)}])
    assert lines == ["Microsoft SideWinder Force Feedback 2 Joystick (045e:001b) has HID PID force feedback but no "
                     "kernel driver gives it through evdev (is hid-pidff loaded? a quirk for this id needed?)"]


# -- the signal paths, in a child process holding a stand-in device --------------------------------

CHILD = """
import socket, sys, time
import numpy as np
sys.path.insert(0, {here!r})
import hidapi_standin
from evdev_standin import FakeDevice, FakeEvdev
from hapticgraph.devices.evdev_ff import EvdevDriver
from hapticgraph.devices.evdev_layout import find
kw = {{}}
if {fd!r} is not None:
    kw["sock"] = socket.socket(fileno={fd!r})
dev = FakeDevice.wheel(log={log!r}, **kw)
fake = FakeEvdev([dev])
device, layout = find({{"path": dev.path}}, fake)
d = EvdevDriver("wheel", {{"max_force": 0.5}}, device, layout, fake)
d.start(44100)
print("playing", flush=True)
t = 0
while True:
    d.send(t, np.full(441, 0.4))
    t += 441
    time.sleep(0.01)
"""


def child(tmp_path, fd=None):
    log = tmp_path / "calls.jsonl"
    code = CHILD.format(here=HERE, fd=fd, log=str(log))
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            pass_fds=(fd,) if fd is not None else ())
    assert proc.stdout.readline().strip() == "playing"
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:              # until it plays the full level
        calls = [json.loads(line) for line in log.read_text().splitlines()]
        if any(c[0] == UPLOAD and c[3] == round(0.4 * FULL) for c in calls):
            break
        time.sleep(0.02)
    return proc, log


def test_sigterm_zeroes_then_erases_the_effect(tmp_path):
    proc, log = child(tmp_path)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=20) == -signal.SIGTERM
    calls = [tuple(json.loads(line)) for line in log.read_text().splitlines()]
    last_full = max(k for k, c in enumerate(calls) if c[0] == UPLOAD and c[3] == round(0.4 * FULL))
    # the watchdog's replays of the effect (every 70 ms here) go on until the signal comes: on a
    # loaded machine one may fall between the last full upload and the signal
    replay = (WRITE, ecodes.EV_FF, 0, 1)
    after = [c for c in calls[last_full + 1:] if c != replay]
    assert after[0] == (UPLOAD, 0, 0xC000, 0)                      # zero before anything else
    assert replay not in calls[calls.index((UPLOAD, 0, 0xC000, 0), last_full):]   # never played after the zero
    assert ("erase", 0) in after and all(c[0] != UPLOAD or c[3] == 0 for c in after)
    assert after.index(("erase", 0)) > 0


def test_sigkill_closes_the_fd_the_effect_was_uploaded_through(tmp_path):
    mine, theirs = socket.socketpair()
    proc, log = child(tmp_path, fd=theirs.fileno())
    theirs.close()
    mine.settimeout(0.3)
    with pytest.raises(TimeoutError):                 # open while the child lives
        mine.recv(1)
    proc.kill()
    assert proc.wait(timeout=20) == -signal.SIGKILL
    mine.settimeout(10)
    assert mine.recv(1) == b""                        # EOF: the kernel would now erase its effects
    calls = [json.loads(line) for line in log.read_text().splitlines()]
    assert not any(c[0] == "erase" for c in calls)    # nothing ran in the child: the fd did it


def test_the_real_python_evdev_is_what_the_driver_asks_for():
    module = evdev_layout.evdev_module()
    assert module.__name__ == "evdev" and module.ecodes.FF_CONSTANT == evdev_layout.FF_CONSTANT
    with pytest.raises(DeviceError, match=r"no input device matches \{name: 'no such device, surely'\}"):
        find({"name": "no such device, surely"}, module)


def test_started_again_after_a_stop_the_node_is_opened_again_and_a_failed_start_is_a_device_error():
    dev = FakeDevice.wheel()
    d = opened_driver(dev)
    d.send(0, np.full(441, 0.2))
    d.stop()
    d.start(RATE)
    d.send(0, np.full(441, 0.2))
    d.stop()
    assert dev.calls.count(("erase", 0)) == 1 and dev.calls.count(("erase", 1)) == 1 and dev.calls[-1] == ("close",)
    assert not dev.handles                               # every handle closed
    dev.fail_after = dev.uploads + 1
    with pytest.raises(DeviceError, match="cannot start its force feedback"):
        d.start(RATE)


def test_the_signal_handler_chains_to_the_one_it_found_and_is_set_again_when_replaced():
    seen = []
    before = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        dev = FakeDevice.wheel()
        d = opened_driver(dev)
        for k in range(10):
            d.send(k * 441, np.full(441, 0.4))
        handler = signal.getsignal(signal.SIGINT)
        assert handler is not None and handler.__module__ == "hapticgraph.devices.evdev_ff"
        handler(signal.SIGINT, None)
        assert seen == [signal.SIGINT] and dev.levels()[-1] == 0       # zeroed, then handed on
        d.send(10 * 441, np.full(441, 0.4))
        assert dev.levels()[-1] == 0                                    # latched until it starts again
        d.stop()
        signal.signal(signal.SIGINT, lambda signum, frame: seen.append(-signum))
        opened_driver(FakeDevice.wheel()).stop()
        signal.getsignal(signal.SIGINT)(signal.SIGINT, None)
        assert seen == [signal.SIGINT, -signal.SIGINT]
    finally:
        signal.signal(signal.SIGINT, before)
