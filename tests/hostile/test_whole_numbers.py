"""Issue 21 item 3: whole numbers written as floats. Where an integer is meant (a cell index, a
count, a number of channels, a byte offset...) `2.0` is read as 2, and `2.5` is refused with
FILE:LINE naming the value: in the patch (lattice `lock:` and `cells:`, integer parameters, the
voices' count), in `--set`, in `--probe`, in cell references and in device profiles. JSON Schema
counts 2.0 as an integer, so before the loader made it one, `[2.0]` passed the schema and ended in
`TypeError: only int indices permitted` (exit 1)."""
import shutil

import numpy as np
import pytest

from hostile_env import assert_patch_error

from hapticgraph.blocks.numbers import whole_number
from hapticgraph.devices.hid_profiles import load_profile
from hapticgraph.graph.errors import PatchError
from hapticgraph.graph.patch import load

STRING = """hapticgraph: 1
rate: 8000
blocks:
  s: {type: lattice, shape: [10], mass: 0.001, tension: 1000.0, lock: [[LOCK]], cells: [{index: [CELL], mass: 0.002}]}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  j: {type: spring, a: "s[9.0]", b: c, tension: 10.0}
  c: {type: cell, mass: 0.001}
  mic: {type: mic}
  out: {type: audio_out, channels: CHANNELS}
connect:
  - hit.out -> s[4].force
  - s[5].velocity -> mic.in
  - mic.left -> out.ch0
"""


def _patch(lock="2.0", cell="3.0", channels="1.0"):
    return STRING.replace("LOCK", lock).replace("CELL", cell).replace("CHANNELS", channels)


def test_the_shared_reading():
    assert [whole_number(v) for v in (2, 2.0, -3.0, "2", " 2.0 ", "-4.00")] == [2, 2, -3, 2, 2, -4]
    assert type(whole_number(2.0)) is int
    for bad in (2.5, "2.5", True, float("nan"), float("inf"), "two", None, "1e3"):
        with pytest.raises(ValueError, match="is not a whole number"):
            whole_number(bad)


def test_whole_floats_in_a_lattice_are_its_integers(write_patch):
    patch = load(write_patch(_patch()))
    s = patch.blocks["s"].values
    assert [list(i) for i in s["lock"]] == [[2]] and all(type(i) is int for i in s["lock"][0])
    assert s["cells"][0]["index"] == [3] and type(s["cells"][0]["index"][0]) is int
    assert patch.blocks["out"].values["channels"] == 1 and type(patch.blocks["out"].values["channels"]) is int


def test_a_run_with_float_indices_matches_the_integer_one(hg, write_patch, tmp_path):
    floats = write_patch(_patch(), "f.yaml")
    ints = write_patch(_patch("2", "3", "1"), "i.yaml")
    for path in (floats, ints):
        proc = hg("run", path, "--seconds", 0.05, "--probe", "s[2.0].position", "--probe", "s[3].velocity",
                  "--quiet", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
    a, b = np.load(tmp_path / "f.npz"), np.load(tmp_path / "i.npz")
    assert np.all(a["s[2.0].position"] == 0.0)                    # the locked cell, read as s[2]
    assert np.abs(a["s[3].velocity"]).max() > 0
    assert np.array_equal(a["s[3].velocity"], b["s[3].velocity"])


@pytest.mark.parametrize("lock,cell,channels,fragment", [
    ("2.5", "3", "1", "parameter 'lock' [0][0]: 2.5 is not an integer"),
    ("2", "3.5", "1", "3.5 is not an integer"),
    ("2", "3", "1.5", "parameter 'channels': 1.5 is not an integer"),
])
def test_fractions_are_refused_where_written(hg, write_patch, lock, cell, channels, fragment):
    path = write_patch(_patch(lock, cell, channels))
    proc = hg("check", path)
    assert_patch_error(proc, fragment)
    assert f"{path}:4:" in proc.stderr or f"{path}:9:" in proc.stderr, proc.stderr


def test_set_and_probe_read_whole_floats(hg, write_patch, tmp_path):
    path = write_patch(_patch("2", "3", "1"))
    proc = hg("run", path, "--seconds", 0.01, "--set", "s.lock=[[7.0]]", "--set", "out.channels=1.0",
              "--out", "o.wav", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = hg("check", path, "--set", "s.lock=[[7.5]]")
    assert_patch_error(proc, "7.5 is not an integer")
    proc = hg("run", path, "--seconds", 0.01, "--probe", "s[2.5].position", cwd=tmp_path)
    assert_patch_error(proc, "[2.5]")


def test_a_voice_count_written_as_a_float(write_patch):
    text = """hapticgraph: 1
rate: 8000
voices:
  count: 3.0
  blocks:
    tone: {type: wavetable, frequency: 220.0}
  connect:
    - tone.out -> out.ch0
blocks:
  out: {type: audio_out, channels: 1}
"""
    patch = load(write_patch(text))
    assert sorted(n for n in patch.blocks if n.endswith("tone")) == ["v1_tone", "v2_tone", "v3_tone"]
    with pytest.raises(PatchError) as err:
        load(write_patch(text.replace("3.0", "2.5"), "q.yaml"))
    assert ":4: voices.count: 2.5 is not an integer" in str(err.value.problems[0]), err.value.problems


def test_profiles_read_whole_floats(tmp_path, patches_dir):
    shipped = patches_dir.parent / "devices" / "profiles" / "haptic_1dof.yaml"
    text = shipped.read_text()
    good = tmp_path / "good.yaml"
    good.write_text(text.replace("report_id: 1", "report_id: 1.0").replace("{byte: 4, size: 16",
                                                                           "{byte: 4.0, size: 16.0"))
    profile, same = load_profile(good), load_profile(shutil.copy(shipped, tmp_path / "same.yaml"))
    assert profile.input == same.input and type(profile.input.report_id) is int
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("{byte: 4, size: 16", "{byte: 4.5, size: 16"))
    with pytest.raises(PatchError) as err:
        load_profile(bad)
    lines = [str(p) for p in err.value.problems]
    assert any(f"{bad}:29:" in line and "4.5 is not a whole number" in line for line in lines), lines
