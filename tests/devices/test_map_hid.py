"""`map:` binds a live parameter to a device's axis as it binds one to a MIDI controller:
`{param: amp.gain, axis: pad.z, min: 2, max: 4}`, with `hold: pad.button1` Cymatic's
suppress-then-jump button — a HID recording (tests/data/hid) and a scripted simulated device
drive them; a wrong device or input is reported at the entry's line."""
import pathlib

import numpy as np
import pytest

import hapticgraph
from hapticgraph.graph.errors import PatchError

PS3 = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid" / "sony_ps3_controller_054c_0268.hid"

PATCH = """hapticgraph: 1
rate: {rate}
devices:
  pad: {device}
blocks:
  one: {{type: constant, value: 1.0}}
  amp: {{type: gain, gain: 0.5}}
  out: {{type: audio_out, channels: 1}}
connect:
  - one.out -> amp.in
  - amp.out -> out.ch0
map:
  - {entry}
"""


def load(tmp_path, entry, device=f"{{driver: hid, recording: {PS3}}}", rate=1000, extra=""):
    path = tmp_path / "p.yaml"
    path.write_text(PATCH.format(rate=rate, device=device, entry=entry) + extra)
    return hapticgraph.load(path)


def test_a_hid_axis_drives_a_parameter_at_the_sample_its_report_is_stamped(tmp_path):
    patch = load(tmp_path, "{param: amp.gain, axis: pad.z, min: 2.0, max: 4.0}")
    assert patch.blocks["map_pad"].cls.type_name == "haptic"          # added: the patch bound pad to no block
    assert list(patch.blocks["map_amp_gain"].values["in_range"]) == [-1.0, 1.0]
    audio = hapticgraph.render(patch, 3.0, chunk=256).audio[:, 0]
    change = 2427                                                    # the report stamped 2.426028 s: z 0x81 -> 0x7c
    assert audio[change - 1] == pytest.approx(3.0 + (2 * 0x81 / 255 - 1))
    assert audio[change] == pytest.approx(3.0 + (2 * 0x7C / 255 - 1))


def test_an_existing_haptic_block_of_the_device_is_used_and_range_and_curve_apply(tmp_path):
    extra = "  - {param: amp.gain, axis: pad.button1, min: 0.5, max: 1.5}\n"      # the device's name
    text = PATCH.format(rate=1000, device=f"{{driver: hid, recording: {PS3}}}",
                        entry="{param: one.value, axis: stick.rz, min: 1.0, max: 100.0, curve: exponential, "
                              "range: [0, 1]}") + extra                             # the block's name
    text = text.replace("  one: {type: constant, value: 1.0}\n",
                        "  one: {type: constant, value: 1.0}\n  stick: {type: haptic, device: pad}\n")
    (tmp_path / "p.yaml").write_text(text)
    patch = hapticgraph.load(tmp_path / "p.yaml")
    assert "map_pad" not in patch.blocks
    assert list(patch.blocks["map_amp_gain"].values["in_range"]) == [0.0, 1.0]    # a button is 0 … 1
    r = hapticgraph.render(patch, 0.5, probes=["stick.rz", "map_one_value.out"], chunk=128)
    rz = r.probes["stick.rz"]
    assert rz.min() > 0.0
    np.testing.assert_allclose(r.probes["map_one_value.out"], 100.0 ** np.clip(rz, 0, 1), rtol=1e-12)
    np.testing.assert_allclose(r.audio[:, 0], 0.5 * 100.0 ** np.clip(rz, 0, 1))   # button1 up: gain 0.5


SCRIPT = ("{driver: simulated, script: [{t: 0, x: 0, z: -1, button1: 0}, {t: 0.01, x: 0, z: 0, button1: 0}, "
          "{t: 0.0101, x: 0, z: 0.01, button1: 1}, {t: 0.02, x: 0, z: 1, button1: 1}, "
          "{t: 0.0201, x: 0, z: 1, button1: 0}], hold: true}")


def test_hold_suppresses_then_jumps(tmp_path):
    patch = load(tmp_path, "{param: amp.gain, axis: pad.z, min: 2.0, max: 4.0, hold: pad.button1}", device=SCRIPT,
                 rate=10000)
    assert patch.blocks["map_amp_gain_hold"].cls.type_name == "sample_hold"
    r = hapticgraph.render(patch, 0.03, probes=["map_pad.z", "map_pad.button1"], chunk=64)
    audio, z, held = r.audio[:, 0], r.probes["map_pad.z"], r.probes["map_pad.button1"] > 0.5
    free = ~held
    np.testing.assert_allclose(audio[free], 3.0 + z[free], atol=1e-12)        # follows the axis while free
    first = np.argmax(held)
    assert held[first:first + 90].all() and np.all(audio[first:first + 90] == audio[first - 1])   # suppressed
    assert audio[first + 50] < 3.0 + z[first + 50] - 0.4
    assert audio[-1] == pytest.approx(4.0)                                   # released: jumps to the axis


@pytest.mark.parametrize("entry, message", [
    ("{param: amp.gain, axis: pda.z, min: 0, max: 1}", "axis 'pda.z': no device named 'pda' under devices: (devices: pad)"),
    ("{param: amp.gain, axis: pad.q, min: 0, max: 1}", "axis 'pad.q': device 'pad' has no input 'q' (its inputs: x, v, "),
    ("{param: amp.gain, axis: pad.z, min: 0, max: 1, hold: pad.nope}", "hold 'pad.nope': device 'pad' has no input"),
    ("{param: amp.gain, axis: pad.z, min: 0, max: 1, smooth: 0.1}", "`smooth` applies to a cc mapping only"),
    ("{param: amp.gain, axis: pad.z, min: 0, max: 1, device: pad}", "`device` applies to a cc or osc mapping"),
    ("{param: amp.gain, cc: 7, min: 0, max: 1, hold: pad.button1}", "`hold` applies to an axis mapping only"),
    ("{param: amp.gain, axis: pad.z, cc: 7, min: 0, max: 1}", "give either `cc: NUMBER`, `osc: /address` or `axis: "),
    ("{param: amp.gian, axis: pad.z}", "no live parameter 'gian'"),
])
def test_wrong_entries_are_reported_at_their_line(tmp_path, entry, message):
    device = f"{{driver: hid, recording: {PS3}}}"
    if "cc:" in entry:
        device += "\n  keys: {driver: midi}"
    with pytest.raises(PatchError) as info:
        load(tmp_path, entry, device=device)
    found = [(p.line, p.message) for p in info.value.problems]
    line = 14 if "cc:" in entry else 13
    assert any(ln == line and message in m and m.startswith("map: param ") for ln, m in found), found
