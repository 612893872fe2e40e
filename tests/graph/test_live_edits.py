"""Edits while playing, applied at block boundaries without recompiling: parameters, and cells
locked, unlocked and cut."""
import numpy as np
import pytest

from analysis import spectral_peak
from hapticgraph.graph.program import PlanError

def session(string_session, editable=True):
    return string_session(4096, editable)


def pitch(s, fmin, fmax, blocks=8):
    y = np.concatenate([s.process(4096)[:, 0].copy() for _ in range(blocks)])
    return spectral_peak(y, 44100.0, fmin, fmax)


def test_lock_the_middle_halves_the_string(string_session):
    s = session(string_session)
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


def test_cut_cell_removes_its_springs(string_session):
    s = session(string_session)
    s.process(4096)
    s.edit(s.prog.edit_cell, "str", (30,), "cut")
    s.process(1)
    net = s.prog.networks[0].net
    assert net.inv_m[30] == 0.0 and net.pos[30] == 0.0
    assert not np.any(net.kr[net.col == 30]) and not np.any(net.kr[net.rowptr[30]:net.rowptr[31]])
    with pytest.raises(PlanError, match="is cut"):
        s.prog.edit_cell("str", (30,), "lock")


def test_set_param_at_block_boundary(string_session):
    s = session(string_session)
    a = s.process(4096)[:, 0].copy()
    s.edit(s.prog.set_param, "mic", "gain", 0.0)
    assert np.any(a != 0.0)
    assert np.all(s.process(4096)[:, 0] == 0.0)


def test_stencil_networks_refuse_cell_edits(string_session):
    s = session(string_session, editable=False)
    with pytest.raises(PlanError, match="editable"):
        s.prog.edit_cell("str", (3,), "lock")
