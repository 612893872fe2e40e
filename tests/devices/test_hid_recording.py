"""`{driver: hid, recording: FILE.hid}`: real hid-recorder recordings (tests/data/hid) played
through the device's own descriptor into a patch, headless: values at the samples their
reports are stamped, the haptic block's x driving a gain through `hapticgraph run`, a mouse's
relative motion falling back to 0, key presses of a keyboard-like pad, and every bad entry or
bad recording reported as FILE:LINE with exit status 2."""
import math
import pathlib
import shutil

import numpy as np
import pytest
from scipy.io import wavfile

import hapticgraph
from hapticgraph import load
from hapticgraph.cli import main
from hapticgraph.devices.hid_recording import RecordingError, load_recording
from hapticgraph.graph.errors import PatchError

CORPUS = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid"
PS3 = CORPUS / "sony_ps3_controller_054c_0268.hid"

GAIN_PATCH = """
hapticgraph: 1
rate: 1000
devices:
  pad: {{driver: hid, recording: {file}}}
blocks:
  stick: {{type: haptic, device: pad}}
  tone: {{type: gain, gain: 0.0}}
  one: {{type: constant, value: 1.0}}
  out: {{type: audio_out, channels: 1}}
connect:
  - one.out -> tone.in
  - stick.x -> tone.gain
  - tone.out -> out.ch0
"""


def test_recording_file():
    rec = load_recording(PS3)
    assert (rec.name, rec.bus, rec.vendor_id, rec.product_id) == ("Sony PLAYSTATION(R)3 Controller", 3, 0x054C, 0x0268)
    assert len(rec.descriptor) == 148 and len(rec.events) == 6
    assert [round(t, 6) for t, _ in rec.events][:3] == [0.0, 0.001008, 0.007007]
    assert all(len(data) == 49 and data[0] == 1 for _, data in rec.events)


def test_the_haptic_x_drives_a_gain_through_hapticgraph_run(write_patch, tmp_path):
    path = write_patch(GAIN_PATCH.format(file=PS3))
    patch = load(path)
    ports = [p.name for p in patch.blocks["stick"].outputs]
    assert ports[:6] == ["x", "v", "button1", "button2", "button3", "button4"] and "y" in ports and "rz" in ports
    out = tmp_path / "x.wav"
    assert main(["run", str(path), "--seconds", "3", "--out", str(out), "--quiet"]) == 0
    rate, audio = wavfile.read(out)
    # the recorded X is 0x8d = 141 of 0…255 throughout: centred, 2·141/255 − 1
    assert rate == 1000 and audio.shape == (3000,)
    np.testing.assert_allclose(audio, 2 * 141 / 255 - 1, rtol=1e-6)


def test_reports_reach_the_samples_they_are_stamped_at(write_patch):
    patch = load(write_patch(GAIN_PATCH.format(file=PS3)))
    r = hapticgraph.render(patch, 3.0, probes=["stick.z", "stick.rz", "stick.y", "stick.button1"], chunk=256)
    z, rz = r.probes["stick.z"], r.probes["stick.rz"]
    change = math.ceil(2.426028 * 1000)          # the report stamped 2.426028 s: z 0x81 -> 0x7c
    assert z[change - 1] == pytest.approx(2 * 0x81 / 255 - 1) and z[change] == pytest.approx(2 * 0x7C / 255 - 1)
    assert rz[change] == pytest.approx(2 * 0x87 / 255 - 1)
    assert rz[math.ceil(2.436050 * 1000)] == pytest.approx(2 * 0x88 / 255 - 1)
    np.testing.assert_allclose(r.probes["stick.y"], 2 * 0x6F / 255 - 1)
    assert not r.probes["stick.button1"].any()


def test_a_mouse_recording_relative_motion_and_a_button(write_patch):
    text = """
    hapticgraph: 1
    rate: 1000
    devices:
      m: {driver: hid, recording: %s}
    blocks:
      pick: {type: haptic, device: m}
    connect: []
    """ % (CORPUS / "genius_gila_mouse_0458_0138.hid")
    patch = load(write_patch(text))
    r = hapticgraph.render(patch, 0.7, probes=["pick.x", "pick.y", "pick.button4"], chunk=64)
    x, b4 = r.probes["pick.x"], r.probes["pick.button4"]
    # times are counted from the first report (3.463836 s); x is the 16-bit change, −32767…32767
    assert x[0] == pytest.approx(-1 / 32767)
    k = math.ceil((3.485822 - 3.463836) * 1000)          # a report of −3
    assert x[k] == pytest.approx(-3 / 32767)
    # silent after 3.503824: the change falls back to 0 within two report intervals (~2 ms)
    quiet = math.ceil((3.503824 - 3.463836) * 1000)
    assert x[quiet] != 0 and x[quiet + 10] == 0
    pressed = math.ceil((3.893813 - 3.463836) * 1000)
    assert b4[pressed - 1] == 0 and b4[pressed] == 1
    released = math.ceil((4.123917 - 3.463836) * 1000)
    assert b4[released - 1] == 1 and b4[released] == 0


def test_a_keyboard_like_pad_presses_keys(write_patch):
    text = """
    hapticgraph: 1
    rate: 1000
    devices:
      pad: {driver: hid, recording: %s}
    blocks:
      pick: {type: haptic, device: pad}
    connect: []
    """ % (CORPUS / "ion_icade_15e4_0132.hid")
    patch = load(write_patch(text))
    r = hapticgraph.render(patch, 1.5, probes=["pick.key_w", "pick.key_e", "pick.key_a"], chunk=100)
    w, e, a = (r.probes[f"pick.key_{k}"] for k in "wea")
    # key codes 0x1a (w) at 0.000001 s, released at 0.001078; 0x08 (e) at 0.238660; 0x04 (a) at 1.063888
    assert w[1] == 1 and w[2] == 0
    assert e[238] == 0 and e[239] == 1 and e[240] == 0
    assert a[1063] == 0 and a[1064] == 1 and a[1066] == 0


# -- bad entries and bad recordings: FILE:LINE, exit 2 ----------------------------------------------

def bad_recording(tmp_path, text):
    path = tmp_path / "bad.hid"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("text, message", [
    ("N: no descriptor\n", "bad.hid: no `R:` line (the report descriptor): not a hid-recorder recording"),
    ("R: 2 05 01\nE: 0.1 2 01 02\nE: 0.05 2 01 02\n", "bad.hid:3: E: the time 0.05 s goes back (the report before is at 0.1 s)"),
    ("R: 2 05 01\nE: soon 2 01 02\n", "bad.hid:2: E: 'soon' is not a time in seconds"),
    ("R: 2 05 01\nE: 0.1 3 01 02\n", "bad.hid:2: E: the length says 3 bytes, the line has 2"),
    ("R: 2 05 01\nX: what\n", "bad.hid:2: 'X: what' is not a line of a hid-recorder recording (D:, R:, N:, P:, I:, E:)"),
    ("R: 2 05 01\nI: 3 zz 01\n", "bad.hid:2: I: expected `BUS VENDOR PRODUCT` in hex"),
])
def test_bad_recordings(tmp_path, text, message):
    with pytest.raises(RecordingError) as info:
        load_recording(bad_recording(tmp_path, text))
    assert str(info.value).replace(str(tmp_path) + "/", "") == message


def test_a_bad_recording_in_a_patch_is_a_patch_error(write_patch, tmp_path, capsys):
    rec = bad_recording(tmp_path, "R: 2 05 01\nE: 0.1 3 01 02\n")
    path = write_patch(GAIN_PATCH.format(file="bad.hid"))
    assert main(["run", str(path), "--seconds", "0.1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{path}:4: device 'pad': recording 'bad.hid': {rec}:2: E: the length says 3 bytes, the line has 2"]


@pytest.mark.parametrize("entry, message", [
    ("{driver: hid}", "device 'pad': driver hid needs one of 'profile'"),
    ("{driver: hid, profile: gamepad, recording: x.hid}", "device 'pad': driver hid needs only one of (it has profile and recording)"),
    ("{driver: hid, recording: missing.hid}", "device 'pad': recording 'missing.hid': "),
    ("{driver: hid, match: {vendr: 1}}", "'vendr'"),
])
def test_bad_entries(write_patch, entry, message):
    path = write_patch(GAIN_PATCH.format(file="X").replace("{driver: hid, recording: X}", entry))
    with pytest.raises(PatchError) as info:
        load(path)
    text = [str(p) for p in info.value.problems]
    assert any(t.startswith(f"{path}:4:") and message in t for t in text), text


def test_a_recording_beside_the_patch(write_patch, tmp_path):
    shutil.copy(PS3, tmp_path / "take.hid")
    patch = load(write_patch(GAIN_PATCH.format(file="take.hid")))
    r = hapticgraph.render(patch, 0.01, probes=["tone.out"])
    np.testing.assert_allclose(r.probes["tone.out"], 2 * 141 / 255 - 1)


def test_a_recording_replaces_another_driver_from_the_command_line(write_patch, tmp_path):
    path = write_patch("""
    hapticgraph: 1
    rate: 1000
    devices:
      pad: {driver: simulated, script: [{t: 0, x: 0.0}]}
    blocks:
      stick: {type: haptic, device: pad}
      g: {type: gain, gain: 1.0}
      out: {type: audio_out, channels: 1}
    connect:
      - stick.x -> g.in
      - g.out -> out.ch0
    """)
    out = tmp_path / "o.wav"
    assert main(["run", str(path), "--seconds", "0.2", "--out", str(out), "--quiet",
                 "--device", f"pad=hid,recording={PS3}"]) == 0
    _, audio = wavfile.read(out)
    np.testing.assert_allclose(audio, 2 * 141 / 255 - 1, rtol=1e-6)
