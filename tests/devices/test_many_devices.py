"""Many devices at once (issue 30 §2): sixteen force-feedback wheels of one model, each on its
reader thread, told apart by `index` (their order in /dev/input) or `serial`; one unplugged
mid-play stops the run naming it, with every other device's force zeroed first and its effect
erased; `hapticgraph run` then writes the WAV whole and exits 1 with one line naming the device.
Against the python-evdev stand-in (tests/devices/evdev_standin.py); two HID pads of one model
through the hidapi stand-in."""
import pathlib
import textwrap
import threading
import time

import numpy as np
import pytest
import soundfile

import hapticgraph
from hapticgraph.cli import main
from hapticgraph.devices import evdev_layout, hid_transports, table
from hapticgraph.devices.evdev_ff import FULL
from hapticgraph.devices.evdev_kind import EvdevKind
from hapticgraph.graph.engine import SafetyStop

import hidapi_standin
from evdev_standin import FakeDevice, FakeEvdev

COUNT = 16
RATE = 44100


def patch_text(count, match, source="{{type: constant, value: {a:g}}}"):
    devices = "".join(f"  w{k}: {{driver: evdev, match: {match(k)}, max_force: 0.5}}\n" for k in range(count))
    blocks = "".join(f"  f{k}: " + source.format(a=0.02 * (k + 1)) + f"\n  h{k}: {{type: haptic, device: w{k}}}\n"
                     for k in range(count))
    connect = "".join(f"  - f{k}.out -> h{k}.force\n  - h{k}.x -> mix.in\n" for k in range(count))
    return textwrap.dedent("""\
        hapticgraph: 1
        rate: 44100
        devices:
        {devices}blocks:
        {blocks}  mix: {{type: gain, gain: 0.1}}
          out: {{type: audio_out, channels: 1}}
        connect:
        {connect}  - mix.out -> out.ch0
        """).format(devices=devices, blocks=blocks, connect=connect)


@pytest.fixture
def wheels(monkeypatch):
    # listed out of order: index counts in /dev/input order (event10 after event9)
    devs = [FakeDevice.wheel(f"/dev/input/event{k + 3}", uniq=f"W{k:02d}") for k in range(COUNT)]
    fake = FakeEvdev(devs[::-1])
    monkeypatch.setattr(evdev_layout, "evdev_module", lambda: fake)
    kinds = {**table.driver_kinds(), "evdev": EvdevKind()}
    monkeypatch.setattr(table, "driver_kinds", lambda: kinds)       # what the command line's loader reads
    return devs


def match(k):
    return f"{{serial: W{k:02d}}}" if k % 5 == 0 else f"{{name: G29, index: {k}}}"


def test_sixteen_wheels_each_on_its_reader_one_unplugged_stops_the_run_others_zeroed_first(wheels, tmp_path):
    path = tmp_path / "many.yaml"
    path.write_text(patch_text(COUNT, match))
    patch = hapticgraph.load(path)
    full = [round(0.02 * (k + 1) * FULL) for k in range(COUNT)]
    with hapticgraph.Session.open(patch, blocksize=64) as s:
        for _ in range(60):
            s.process(64)
        readers = {t.name for t in threading.enumerate() if t.name.startswith("evdev-")}
        assert readers == {f"evdev-w{k}-reader" for k in range(COUNT)}
        for k, dev in enumerate(wheels):                          # each wheel plays its own device's force
            assert dev.levels()[-1] == full[k], k
        wheels[7].unplug()
        deadline = time.monotonic() + 5
        while not all(d.levels()[-1] == 0 for k, d in enumerate(wheels) if k != 7) and time.monotonic() < deadline:
            time.sleep(0.01)
        for k, dev in enumerate(wheels):
            if k != 7:
                assert dev.levels()[-1] == 0, k                    # zeroed before the run has even stopped
        with pytest.raises(SafetyStop, match="device 'w7' stopped answering: read failed"):
            s.process(64)
        for k, dev in enumerate(wheels):
            if k != 7:
                assert dev.levels()[-1] == 0, k                    # the last block sent them nothing
    for k, dev in enumerate(wheels):
        if k != 7:
            calls = dev.ff_calls()
            assert [c[0] for c in calls[-3:]] == ["write", "erase", "write"] and dev.calls[-1] == ("close",), k
            assert calls[-2] == ("erase", 0) and calls[-1][3] == 0xFFFF


def test_run_writes_the_wav_whole_and_names_the_lost_device(wheels, tmp_path, capsys):
    wheels[2].fail_after = 5                                      # its 5th force write: unplugged
    path = tmp_path / "three.yaml"
    sine = "{{type: wavetable, shape: sine, frequency: 1.0, amplitude: {a:g}}}"     # a new level every block
    path.write_text(patch_text(3, lambda k: f"{{name: G29, index: {k}}}", sine))
    out = tmp_path / "take.wav"
    assert main(["run", str(path), "--seconds", "5", "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "device 'w2' stopped answering: force write failed" in err[0], err
    audio, rate = soundfile.read(out)                             # a whole file: its header says its length
    assert rate == RATE and 0 < len(audio) < 5 * RATE and np.all(np.isfinite(audio))
    for dev in wheels[:2]:
        levels = dev.levels()
        assert levels[-1] == 0 and max(levels) > 0
        assert ("erase", 0) in dev.ff_calls()[-2:]


def test_two_hid_pads_of_one_model_told_apart_by_serial_and_index(monkeypatch, tmp_path):
    ps3 = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid" / "sony_ps3_controller_054c_0268.hid"
    fake = hidapi_standin.FakeHidapi([hidapi_standin.FakeDevice.from_recording(ps3, b"/dev/hidraw4", serial="PAD-B"),
                                      hidapi_standin.FakeDevice.from_recording(ps3, b"/dev/hidraw5", serial="PAD-A")])
    monkeypatch.setattr(hid_transports, "hid_module", lambda: fake)
    path = tmp_path / "pads.yaml"
    path.write_text(textwrap.dedent("""\
        hapticgraph: 1
        rate: 1000
        devices:
          left: {driver: hid, match: {vendor: 0x054c, product: 0x0268, serial: PAD-A}}
          right: {driver: hid, match: {vendor: 0x054c, index: 0}}
        blocks:
          l: {type: haptic, device: left}
          r: {type: haptic, device: right}
          out: {type: audio_out, channels: 2}
        connect:
          - l.x -> out.left
          - r.x -> out.right
        """))
    patch = hapticgraph.load(path)
    with hapticgraph.Session.open(patch, blocksize=64) as s:
        s.process(64)
        readers = {t.name for t in threading.enumerate() if t.name.startswith("hid-")}
        paths = {name: d.transport.path for name, d in s.drivers.items()}
    assert paths == {"left": "/dev/hidraw5", "right": "/dev/hidraw4"}
    assert readers >= {"hid-left-reader", "hid-right-reader"}
