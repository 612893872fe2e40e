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
    net = s.prog.groups[0].group
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


DELAY = """
hapticgraph: 1
rate: 44100
blocks:
  loop: {type: delay, length: 37}
  out: {type: audio_out, channels: 1}
connect:
  - loop.out -> out.ch0
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_state_views_of_a_delay_are_its_state_and_ring_buffer(write_patch, engine):
    """state_views: the State slot, then the ring buffer; writing into the buffer is what the next
    kernel call reads: 37 samples of it come out, then the silence the line was fed."""
    from hapticgraph import load
    from hapticgraph.graph.engine import Runner
    s = Runner(load(write_patch(DELAY)), probes=("loop.out",), engine=engine, blocksize=64)
    views = s.prog.state_views("loop")
    assert len(views) == 2 and views[0].shape == (1,) and len(views[1]) >= 39
    assert all(v.flags.writeable for v in views)
    views[1][:] = 0.25
    y = s.process(64)[:, -1].copy()
    assert np.all(y[:37] == 0.25) and np.all(y[37:] == 0.0)
    assert s.prog.state_views("out") == ()
    with pytest.raises(PlanError, match="no block named"):
        s.prog.state_views("lop")


def test_state_views_of_a_lattice_are_its_positions_and_velocities(string_session):
    """A lattice carries no State slots or buffers: its views are its cells' positions and
    velocities, in that order; the kernel reads what is written into them."""
    still = string_session(64)
    moved = string_session(64)
    pos, vel = moved.prog.state_views("str")
    assert pos.shape == vel.shape == (41,) and pos.flags.writeable and vel.flags.writeable
    vel[12] = 1.0                     # the mic hears str[12].velocity
    a, b = still.process(1)[0, 0], moved.process(1)[0, 0]
    assert a == 0.0 and b != 0.0
    pos, vel = moved.prog.state_views("str")
    assert pos[12] != 0.0             # the kick moved the cell
    before = vel.copy()
    pos[30] = 1e-3                   # displaced: its springs pull it back at the next sample
    moved.process(1)
    assert vel[30] < 0.0 and vel[30] != before[30]
