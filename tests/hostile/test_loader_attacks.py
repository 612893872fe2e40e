"""Hostile patches against the loader (issue 10 items 4, 5, 7): budgets before work, only
regular files, bounded error floods, no tags, and every bad input a FILE:LINE error, exit 2."""
import os
import time

import numpy as np
import pytest

from hostile_env import assert_patch_error, run_hg

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
KARPLUS = os.path.join(ROOT, "patches", "karplus_strong.yaml")

LATTICE = """hapticgraph: 1
blocks:
  s: {type: lattice, shape: [8]}
  m: {type: mic}
  p: {type: pluck}
  out: {type: audio_out}
connect:
  - p.out -> s[3].force
  - CONNECTION
  - m.left -> out.left
"""


def write(tmp_path, text, name="p.yaml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_merge_bomb_is_refused_at_once(tmp_path):
    lines = ["hapticgraph: 1", "a0: &a0 {x: 1, y: 2}"]
    lines += [f"a{i}: &a{i} {{<<: [{', '.join([f'*a{i - 1}'] * 8)}]}}" for i in range(1, 12)]
    path = write(tmp_path, "\n".join(lines + ["blocks: {}"]) + "\n")
    assert path.stat().st_size < 700
    proc = run_hg("check", path, timeout=30)
    assert_patch_error(proc, "merge bomb")
    assert f"{path}:8: " in proc.stderr


def test_self_merge_is_a_clean_error(tmp_path):
    path = write(tmp_path, "hapticgraph: 1\na: &a {<<: *a}\nblocks: {}\n")
    proc = run_hg("check", path)
    assert_patch_error(proc, f"{path}:2: *a is used inside the value &a names (a recursive structure)")


@pytest.mark.parametrize("value, message", [
    (".nan", "'.nan': numbers must be finite"),
    ("1e999", "'1e999': numbers must be finite"),
    ("!!binary aGk=", "tags are not allowed"),
    ("9" * 5000, "numbers have at most 100 digits"),
])
def test_set_values_pass_the_loader_guards(value, message):
    proc = run_hg("check", KARPLUS, "--set", f"damp.gain={value}")
    assert_patch_error(proc, message)
    assert f"{KARPLUS}:11: --set " in proc.stderr


def test_set_naming_a_missing_parameter_or_block_lists_the_valid_ones():
    proc = run_hg("check", KARPLUS, "--set", "damp.gian=0.5")
    assert_patch_error(proc, "block 'damp' (lowpass) has no parameter 'gian' (did you mean 'gain'?); "
                             "its parameters: coeffs, gain")
    proc = run_hg("check", KARPLUS, "--set", "dmp.gain=0.5")
    assert_patch_error(proc, "no block named 'dmp' (did you mean 'damp'?); its blocks: pick, loop, damp, mic, out")


@pytest.mark.parametrize("kind", ["fifo", "directory"])
def test_a_fifo_or_a_directory_is_refused_without_blocking(tmp_path, kind):
    path = tmp_path / "p.yaml"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.mkdir()
    proc = run_hg("check", path, timeout=30)      # reading a FIFO would block until the timeout
    assert_patch_error(proc, f"{path}:1: the patch is {'a FIFO' if kind == 'fifo' else 'a directory'}")


def test_an_error_flood_stops_after_a_bounded_number_of_messages(tmp_path):
    path = tmp_path / "flood.yaml"
    with open(path, "w", encoding="utf-8") as f:
        f.write("hapticgraph: 1\nblocks:\n")
        while f.tell() < 3_900_000:
            f.write("  x: {type: gain}\n")
    start = time.monotonic()
    proc = run_hg("check", path, timeout=60)
    seconds = time.monotonic() - start
    assert_patch_error(proc, "duplicate key 'x' (first at line 3)")
    lines = proc.stderr.strip().splitlines()
    assert len(lines) <= 101, len(lines)
    assert lines[-1] == f"{path}:103: stopped after 100 problems: the rest of the file not checked"
    assert seconds < 10, seconds       # the issue asks for 2 s; this machine is shared


@pytest.mark.parametrize("text, line, message", [
    ("hapticgraph: 1\n? !!python/name:os.system x\n: 1\nblocks: {}\n", 2, "tags are not allowed"),
    ("hapticgraph: 1\n? !!binary aGk=\n: 1\nblocks: {}\n", 2, "tags are not allowed"),
    ("hapticgraph: 1\nblocks:\n  g: !custom {type: gain}\n", 3, "tags are not allowed in a patch (found '!custom')"),
    ("hapticgraph: 1\nblocks:\n  g: {type: gain, gain: " + "9" * 5000 + "}\n", 3,
     "a number 5000 characters long"),
    ("hapticgraph: 1\nplugins: ['']\nblocks: {}\n", 2, "plugins.0: must not be empty"),
    ("hapticgraph: 1\nplugins: [3]\nblocks: {}\n", 2, "plugins.0: 3 is not a string"),
    ("hapticgraph: 1\nplugins: my_blocks\nblocks: {}\n", 2, "plugins: 'my_blocks' is not an array"),
    ("hapticgraph: 1\nplugins: ['..', 'a b']\nblocks: {}\n", 2, "is neither a module name"),
    ("hapticgraph: 1\nblocks:\n  g: {type: gain, gain: yes}\n", 3, "'yes' is not a number"),
    ("hapticgraph: 1\nblocks:\n  \"a\\n\": {type: gain}\n", 2, "is not a valid name"),
])
def test_bad_inputs_are_file_line_errors(tmp_path, text, line, message):
    path = write(tmp_path, text)
    proc = run_hg("check", path)
    assert_patch_error(proc)
    assert any(ln.startswith(f"{path}:{line}: ") and message in ln for ln in proc.stderr.splitlines()), proc.stderr


def test_yaml_1_1_booleans_are_the_strings_they_look_like(tmp_path):
    path = write(tmp_path, "hapticgraph: 1\nblocks:\n  on: {type: gain}\n  no: {type: gain}\n"
                           "connect: [on.out -> no.in]\n")
    proc = run_hg("check", path)
    assert proc.returncode == 0, proc.stderr
    assert "schedule: on -> no" in proc.stdout


@pytest.mark.parametrize("connection, index", [
    ("s[1.5].position -> m.in", "[1.5]"), ("s[].position -> m.in", "[]"), ("p.out -> s[1-2].force", "[1-2]")])
def test_unreadable_cell_indices_in_connections(tmp_path, connection, index):
    path = write(tmp_path, LATTICE.replace("CONNECTION", connection))
    proc = run_hg("check", path)
    assert_patch_error(proc, f"{path}:9: cannot read {connection!r}: the cell index {index} must be whole numbers")


@pytest.mark.parametrize("probe, message", [
    ("s[].position", "the cell index [] must be whole numbers"),
    ("s[1-2].force", "the cell index [1-2] must be whole numbers"),
    ("s[1.5].position", "the cell index [1.5] must be whole numbers"),
    ("m.lft", "block 'm' (mic) has no port or state 'lft' (did you mean 'left'?); it has: left, right, in, gain, pan"),
    ("s[3].pos", "a cell has no port 'pos'; its ports: force (input), position, velocity (outputs)"),
    ("q.out", "no block named 'q'; its blocks: s, m, p, out"),
])
def test_bad_probes_are_usage_errors(tmp_path, probe, message):
    path = write(tmp_path, LATTICE.replace("CONNECTION", "s[2].position -> m.in"))
    proc = run_hg("run", path, "--seconds", "0.01", "--quiet", "--engine", "python",
                  "--out", tmp_path / "o.wav", "--probe", probe)
    assert_patch_error(proc, f"hapticgraph: error: probe {probe!r}: {message}")


@pytest.mark.parametrize("engine", ["python", "compiled"])
def test_a_cell_force_can_be_probed(tmp_path, engine):
    path = write(tmp_path, LATTICE.replace("CONNECTION", "s[2].position -> m.in"))
    proc = run_hg("run", path, "--seconds", "0.01", "--quiet", "--engine", engine, "--out", tmp_path / "o.wav",
                  "--probe", "s[3].force", "--probe", "s[2].force", "--probe", "p.out")
    assert proc.returncode == 0, proc.stderr
    probes = np.load(tmp_path / "o.npz")
    assert np.abs(probes["s[3].force"]).max() > 0.5
    np.testing.assert_array_equal(probes["s[3].force"], probes["p.out"])
    assert not probes["s[2].force"].any()


def test_the_cell_cap_counts_all_lattices_together(tmp_path):
    path = write(tmp_path, "hapticgraph: 1\nblocks:\n  a: {type: lattice, shape: [4000, 4000]}\n"
                           "  b: {type: lattice, shape: [4000, 4000]}\n")
    proc = run_hg("check", path)
    assert_patch_error(proc, f"{path}:4: block 'b' (lattice): with it the patch has 32,000,000 cells")
    assert "at most 20,000,000 cells are allowed in one patch" in proc.stderr


def test_check_of_a_huge_lattice_allocates_nothing_big(tmp_path):
    path = write(tmp_path, "hapticgraph: 1\nblocks:\n  a: {type: lattice, shape: [4000, 4000], tension: 1}\n")
    proc = run_hg("check", path, memory_mb=1024)   # its arrays alone would take 2.5 GB
    assert proc.returncode == 0, proc.stderr
    assert "ok: 1 blocks" in proc.stdout


def test_a_huge_unstable_lattice_is_still_refused_at_check(tmp_path):
    path = write(tmp_path, "hapticgraph: 1\nblocks:\n  a: {type: lattice, shape: [4000, 4000], tension: 1e9}\n")
    proc = run_hg("check", path, memory_mb=1024)
    assert_patch_error(proc, f"{path}:3: block 'a' (lattice): unstable at 44100 Hz: cell a[0, 0]")


def test_a_graph_too_large_to_compile_is_refused_with_its_size(tmp_path):
    n = 1001
    lines = ["hapticgraph: 1", "blocks:"] + [f"  g{i}: {{type: gain}}" for i in range(n)]
    lines += ["connect:"] + [f"  - g{i}.out -> g{i + 1}.in" for i in range(n - 1)]
    path = write(tmp_path, "\n".join(lines) + "\n")
    proc = run_hg("run", path, "--seconds", "0.01", "--out", tmp_path / "o.wav")
    assert_patch_error(proc, f"{path}:2: the patch has 1,001 blocks to compile")
    assert "at most 1,000" in proc.stderr


def test_a_lattice_live_parameter_is_probed_without_an_index(tmp_path):
    path = write(tmp_path, LATTICE.replace("CONNECTION", "s[2].position -> m.in"))
    proc = run_hg("run", path, "--seconds", "0.01", "--quiet", "--engine", "python", "--out", tmp_path / "o.wav",
                  "--probe", "s.tension")
    assert proc.returncode == 0, proc.stderr
    assert (np.load(tmp_path / "o.npz")["s.tension"] == 100.0).all()
