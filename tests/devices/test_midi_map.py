"""The `map:` section: a live parameter bound to a MIDI controller (or an OSC address) without
wiring, expanded into ordinary blocks; `hapticgraph check` reports a wrong entry at its line,
naming the parameter; the blocks a controller plays must name a device that can play them."""
import mido
import numpy as np
import pytest

import hapticgraph
from hapticgraph.devices.midi import write_midi_file
from hapticgraph.graph.errors import PatchError

PATCH = """hapticgraph: 1
rate: 48000
devices:
  song: {driver: midi, file: song.mid}
blocks:
  src: {type: constant, value: 1.0}
  amp: {type: gain, gain: 0.5}
  out: {type: audio_out, channels: 1}
connect:
  - src.out -> amp.in
  - amp.out -> out.ch0
map:
"""


def _load(tmp_path, entries, devices=None):
    write_midi_file(tmp_path / "song.mid", [(100, mido.Message("control_change", control=74, value=127)),
                                            (300, mido.Message("control_change", control=74, value=0))], 48000)
    text = PATCH + "".join(f"  - {e}\n" for e in entries)
    if devices is not None:
        text = text.replace("  song: {driver: midi, file: song.mid}\n", devices)
    (tmp_path / "p.yaml").write_text(text)
    return hapticgraph.load(tmp_path / "p.yaml")


def test_cc_drives_a_live_parameter_at_its_sample(tmp_path):
    patch = _load(tmp_path, ["{param: amp.gain, cc: 74, min: 2.0, max: 4.0}"])
    assert "map_amp_gain" in patch.blocks
    for engine in ("compiled", "python"):
        audio = hapticgraph.render(patch, 0.01, engine=engine, chunk=128).audio[:, 0]
        assert np.all(audio[:100] == 2.0) and np.all(audio[100:300] == 4.0) and np.all(audio[300:] == 2.0)


def test_exponential_curve(tmp_path):
    patch = _load(tmp_path, ["{param: amp.gain, cc: 74, min: 10.0, max: 1000.0, curve: exponential}"])
    audio = hapticgraph.render(patch, 0.01).audio[:, 0]
    assert audio[99] == 10.0 and audio[100] == pytest.approx(1000.0, rel=1e-12)


def _problems(tmp_path, entries, devices=None):
    with pytest.raises(PatchError) as info:
        _load(tmp_path, entries, devices)
    return [(p.line, p.message) for p in info.value.problems]


def test_errors_name_the_param_at_its_line(tmp_path):
    found = _problems(tmp_path, ["{param: amp.gian, cc: 74, min: 0, max: 1}",      # line 13
                                 "{param: nope.gain, cc: 1}",                       # line 14
                                 "{param: amp.gain, cc: 7, min: 0, max: 2.0e6}",    # line 15: over 1e6
                                 "{param: amp.gain, cc: 7, min: -1, max: 1, curve: exponential}",
                                 "{param: amp.gain, osc: /g, min: 0, max: 1}",      # no OSC device
                                 "{param: amp.gain, min: 0, max: 1}"])              # neither cc nor osc
    lines = dict(found)
    assert "map: param 'amp.gian'" in lines[13] and "no live parameter 'gian'" in lines[13]
    assert "map: param 'nope.gain'" in lines[14] and "no block named 'nope'" in lines[14]
    assert "max 2e+06 is outside the parameter's range" in lines[15]
    assert "exponential" in lines[16]
    assert "osc_in" in lines[17]
    assert "either `cc" in lines[18]


def test_device_must_be_named_when_ambiguous(tmp_path):
    devices = "  a: {driver: midi}\n  b: {driver: midi}\n"
    found = _problems(tmp_path, ["{param: amp.gain, cc: 74, min: 0, max: 1}"], devices)
    assert any("say which `device:`" in m and "a, b" in m for _, m in found)
    patch = _load(tmp_path, ["{param: amp.gain, cc: 74, min: 0, max: 1, device: b}"], devices)
    assert patch.blocks["map_amp_gain"].values["device"] == "b"


def test_controller_blocks_need_a_controller(write_patch):
    text = """hapticgraph: 1
devices:
  hand: {driver: simulated}
blocks:
  n: {type: midi_note, device: hand}
  m: {type: midi_cc}
  o: {type: osc_in, device: ghost}
"""
    with pytest.raises(PatchError) as info:
        hapticgraph.load(write_patch(text))
    messages = {p.line: p.message for p in info.value.problems}
    assert "cannot play a midi_note" in messages[5]
    assert "name the device" in messages[6]
    assert "no device named 'ghost'" in messages[7]


def test_check_cli_reports_file_and_line(tmp_path, hg):
    _load(tmp_path, ["{param: amp.gain, cc: 74, min: 0, max: 1}"])
    text = (tmp_path / "p.yaml").read_text().replace("amp.gain", "amp.gian")
    (tmp_path / "p.yaml").write_text(text)
    proc = hg("check", tmp_path / "p.yaml")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert f"{tmp_path / 'p.yaml'}:13: map: param 'amp.gian'" in proc.stderr
