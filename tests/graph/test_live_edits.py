"""Edits while playing, applied at block boundaries without recompiling: parameters, and cells
locked, unlocked and cut."""
import numpy as np
import pytest

from analysis import spectral_peak
from hapticgraph import load
from hapticgraph.devices import open_drivers
from hapticgraph.graph.engine import Session
from hapticgraph.graph.program import PlanError

STRING = """
hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [41], mass: 0.001, tension: 200000.0}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  mic: {type: mic}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> str[5].force
  - str[12].velocity -> mic.in
  - mic.left -> out.ch0
"""


def session(write_patch, editable=True):
    patch = load(write_patch(STRING))
    return Session(patch, drivers=open_drivers(patch), blocksize=4096, editable=editable)


def pitch(s, fmin, fmax, blocks=8):
    y = np.concatenate([s.process(4096)[:, 0].copy() for _ in range(blocks)])
    return spectral_peak(y, 44100.0, fmin, fmax)


def test_lock_the_middle_halves_the_string(write_patch):
    s = session(write_patch)
    f_full = pitch(s, 100, 250)
    s.edit(s.prog.edit_cell, "str", (20,), "lock")     # a node in the middle: each half is 20 cells
    s.edit(s.prog.set_param, "hit", "force", 0.5)
    f_half = pitch(s, 250, 400)
    # 41 cells between fixed ends vs 20: ω = 2√(T/m)·sin(π/(2(N+1))), then the half-step
    # correction f = fs/π·asin(ω/(2fs)): 168.32 Hz → 336.44 Hz
    w = lambda n: 44100 / np.pi * np.arcsin(np.sqrt(2e8) * np.sin(np.pi / (2 * (n + 1))) / 44100)
    assert f_full == pytest.approx(w(41), rel=0.002)
    assert f_half == pytest.approx(w(20), rel=0.002)
    s.edit(s.prog.edit_cell, "str", (20,), "unlock")
    s.process(4096)


def test_cut_cell_removes_its_springs(write_patch):
    s = session(write_patch)
    s.process(4096)
    s.edit(s.prog.edit_cell, "str", (30,), "cut")
    s.process(1)
    net = s.prog.networks[0].net
    assert net.inv_m[30] == 0.0 and net.pos[30] == 0.0
    assert not np.any(net.kr[net.col == 30]) and not np.any(net.kr[net.rowptr[30]:net.rowptr[31]])
    with pytest.raises(PlanError, match="is cut"):
        s.prog.edit_cell("str", (30,), "lock")


def test_set_param_at_block_boundary(write_patch):
    s = session(write_patch)
    a = s.process(4096)[:, 0].copy()
    s.edit(s.prog.set_param, "mic", "gain", 0.0)
    assert np.any(a != 0.0)
    assert np.all(s.process(4096)[:, 0] == 0.0)


def test_stencil_networks_refuse_cell_edits(write_patch):
    s = session(write_patch, editable=False)
    with pytest.raises(PlanError, match="editable"):
        s.prog.edit_cell("str", (3,), "lock")
