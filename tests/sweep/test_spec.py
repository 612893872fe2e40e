"""The sweep file: every key, axis and value checked by the patch loader before anything is
submitted, each problem a `FILE:LINE` of the sweep file and exit 2; the samplers; --dry-run."""
import subprocess
import sys

import pytest

from hapticgraph.graph.errors import PatchError
from hapticgraph.sweeps import load_spec
from sweeps_env import crash_patch, karplus, lattice, write


def _problems(path):
    with pytest.raises(PatchError) as err:
        load_spec(path)
    return [str(p) for p in err.value.problems]


def test_unknown_keys_blocks_parameters_features_and_choices_are_told_at_their_lines(tmp_path):
    karplus(tmp_path)
    path = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        axes:
          damp.gian: [0.9]
          nope.x: [1]
          mic.gain: {min: 0.1, max: 0.5, count: 3, scale: lin}
        features: [f0, t6]
        audio: mp3
        colour: red
        """)
    problems = _problems(path)
    assert f"{path}:4: axes: damp.gian: block 'damp' (lowpass) has no parameter 'gian' (did you mean 'gain'?)" \
           in "\n".join(problems)
    assert any(p.startswith(f"{path}:5: axes: nope.x: the patch has no block named 'nope'") for p in problems)
    assert any(p.startswith(f"{path}:6: scale: 'lin' is not one of linear, log") for p in problems)
    assert any(p.startswith(f"{path}:7: features: unknown feature 't6' (did you mean 't60'?)") for p in problems)
    assert any(p.startswith(f"{path}:8: audio: 'mp3'") for p in problems)
    assert any(p.startswith(f"{path}:9: unknown key 'colour'") for p in problems)


def test_a_value_out_of_range_or_of_the_wrong_kind_is_told_at_its_own_line(tmp_path):
    karplus(tmp_path)
    path = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        axes:
          loop.length:
            - 99
            - -5
            - "long"
          mic.pan: {min: -2, max: 0.5, count: 3}
        set: [mic.gain=0.4]
        """)
    problems = _problems(path)
    assert f"{path}:6: loop.length=-5: block 'loop' (delay): parameter 'length': -5 is below the minimum 1.0 samples" \
        in problems
    assert any(p.startswith(f"{path}:7: loop.length=\"long\": block 'loop' (delay): parameter 'length'") for p in problems)
    assert any(p.startswith(f"{path}:8: mic.pan=-2.0: block 'mic' (mic): parameter 'pan': -2") for p in problems)
    assert len(problems) == 3


def test_a_bad_set_item_names_its_line(tmp_path):
    karplus(tmp_path)
    path = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        axes: {damp.gain: [0.99]}
        set:
          - mic.pan=0.0
          - mic.pan=7
        """)
    assert _problems(path) == [f"{path}:6: mic.pan=7: block 'mic' (mic): parameter 'pan': 7 is above the maximum 1.0"]


def test_stability_of_a_combination_is_told_with_its_variant(tmp_path):
    """Each mass and each tension is stable alone; the light mass with the high tension is not."""
    lattice(tmp_path)
    path = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: string.yaml
        axes:
          s.mass: [0.001, 0.0001]
          s.tension: [100000.0, 1000000.0]
        """)
    problems = _problems(path)
    assert len(problems) == 1, problems
    assert problems[0].startswith(f"{path}:4: ") and "variant 3 (s.mass=0.0001, s.tension=1000000.0)" in problems[0]
    assert "stab" in problems[0]


def test_samplers_make_count_points_in_the_ranges_from_a_seed(tmp_path):
    karplus(tmp_path)
    for sampler in ("random", "lhs", "sobol"):
        text = f"""
            sweep: 1
            patch: ks.yaml
            sampler: {sampler}
            seed: 5
            count: 12
            axes:
              damp.gain: {{min: 0.9, max: 0.999, scale: log}}
              loop.length: {{min: 50, max: 120, step: 1}}
              mic.pan: [-0.5, 0.0, 0.5]
            """
        spec = load_spec(write(tmp_path, f"{sampler}.yaml", text))
        again = load_spec(write(tmp_path, f"{sampler}2.yaml", text))
        assert [v.values for v in spec.variants] == [v.values for v in again.variants]
        assert len(spec.variants) == 12 and len({v.id for v in spec.variants}) == 12
        for gain, length, pan in (v.values for v in spec.variants):
            assert 0.9 <= gain <= 0.999 and 50 <= length <= 120 and length == round(length) and pan in (-0.5, 0.0, 0.5)
    lhs = load_spec(tmp_path / "lhs.yaml")
    bins = sorted(int((v.values[1] - 50) / 70 * 12) for v in lhs.variants)
    assert len(set(bins)) >= 10                               # a Latin hypercube: one point per stratum


def test_grid_ids_change_with_the_patch_its_plugin_and_the_duration(tmp_path):
    crash_patch(tmp_path)
    path = write(tmp_path, "s.yaml", "sweep: 1\npatch: crash.yaml\naxes: {damp.gain: [0.99, 0.995]}\n")
    first = [v.id for v in load_spec(path).variants]
    assert len(set(first)) == 2 and first == [v.id for v in load_spec(path).variants]
    (tmp_path / "crash.py").write_text((tmp_path / "crash.py").read_text() + "\n# edited\n")
    assert [v.id for v in load_spec(path).variants] != first
    write(tmp_path, "s.yaml", "sweep: 1\npatch: crash.yaml\nseconds: 2.0\naxes: {damp.gain: [0.99, 0.995]}\n")
    assert not set(v.id for v in load_spec(path).variants) & set(first)


def test_cli_dry_run_prints_the_table_and_a_bad_file_exits_2(tmp_path):
    karplus(tmp_path)
    good = write(tmp_path, "s.yaml", "sweep: 1\npatch: ks.yaml\naxes:\n  loop.length: [99, 149]\n  damp.gain: [0.99]\n")
    done = subprocess.run([sys.executable, "-m", "hapticgraph", "sweep", str(good), "--out", str(tmp_path / "o"),
                           "--dry-run"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split() == ["#", "id", "loop.length", "damp.gain"] and lines[2].split()[2:] == ["149", "0.99"]
    assert "2 variant(s)" in lines[-1] and not (tmp_path / "o").exists()
    bad = write(tmp_path, "b.yaml", "sweep: 1\npatch: ks.yaml\naxes:\n  loop.length: [0]\n")
    done = subprocess.run([sys.executable, "-m", "hapticgraph", "sweep", str(bad), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.startswith(f"{bad}:4: loop.length=0:") and "Traceback" not in done.stderr
