"""Sizes reach the kernel as data (issue "One IR", item 5): editing a lattice's shape, the cells a
patch drives or reads, a delay's length, a filter's taps or the rate re-uses the compiled kernel;
only a change of structure (another block, another wiring, a flag, a delay ring's power-of-two
capacity) compiles a new one. The cache entries on disk are counted."""
import numpy as np
import pytest

from hapticgraph import render
from hapticgraph.graph import kernel
from hapticgraph.graph.patch import load

PATCH = """\
hapticgraph: 1
rate: {rate}
blocks:
  str:   {{type: lattice, shape: {shape}, mass: 0.0002, tension: {tension}, damping: 0.001}}
  pick:  {{type: pluck, time: 0.0, force: 1.0, duration: 0.001}}
  loop:  {{type: delay, length: {length}}}
  damp:  {{type: lowpass, coeffs: {coeffs}, gain: 0.99}}
  mic:   {{type: mic, gain: 1.0}}
  out:   {{type: audio_out, channels: 2}}
connect:
  - pick.out -> str{at}.force
  - str{read}.velocity -> loop.in
  - loop.out -> damp.in
  - damp.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""
BASE = dict(rate=44100, shape="[60]", tension=144100.0, length=99, coeffs="[0.25, 0.5, 0.25]", at="[12]",
            read="[50]")
EDITS = [dict(shape="[61]"), dict(shape="[200]", at="[150]", read="[3]"), dict(length=120),
         dict(coeffs="[0.1, 0.2, 0.3, 0.4]"), dict(rate=48000, tension=100000.0),
         dict(shape="[8, 8]", at="[2, 3]", read="[5, 5]")]


def _entries(cache):
    return sorted(p.name for p in cache.iterdir() if p.name.startswith("kernel_"))


def _render(tmp_path, name, **values):
    path = tmp_path / f"{name}.yaml"
    path.write_text(PATCH.format(**{**BASE, **values}))
    return render(load(path), 0.01)


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(cache))
    monkeypatch.setattr(kernel, "_loaded", {})      # nothing this process compiled before counts
    return cache


def test_editing_sizes_reuses_the_compiled_kernel(tmp_path, fresh_cache):
    first = _render(tmp_path, "base")
    assert len(_entries(fresh_cache)) == 1
    for k, edit in enumerate(EDITS[:-1]):
        result = _render(tmp_path, f"edit{k}", **edit)
        assert np.all(np.isfinite(result.audio)) and np.max(np.abs(result.audio)) > 0, edit
        assert len(_entries(fresh_cache)) == 1, f"{edit} compiled a new kernel: {_entries(fresh_cache)}"
    assert not np.array_equal(first.audio, result.audio)     # the edits did change the sound


def test_a_change_of_structure_compiles_a_new_kernel(tmp_path, fresh_cache):
    _render(tmp_path, "base")
    _render(tmp_path, "sheet", **EDITS[-1])      # a 2-D lattice runs another step function
    assert len(_entries(fresh_cache)) == 2


@pytest.mark.parametrize("edit", EDITS, ids=[next(iter(e)) + str(k) for k, e in enumerate(EDITS)])
def test_edited_sizes_compiled_equals_interpreter(tmp_path, edit):
    path = tmp_path / "p.yaml"
    path.write_text(PATCH.format(**{**BASE, **edit}))
    a = render(load(path), 0.005, engine="compiled")
    b = render(load(path), 0.005, engine="python")
    np.testing.assert_array_equal(a.audio, b.audio)
