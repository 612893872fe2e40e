"""The studio's body carry (hapticgraph/studio/adapter.py `body_carry`) between programs whose
lattices run on a stencil (one pass over positions now and one sample before, inside a ghost
border: views that are not contiguous, velocities computed) or on the CSR lists (velocities
stored): the new program's cells take the old one's motion, read at the swap."""
import numpy as np
import pytest

from hapticgraph import load
from hapticgraph.graph.engine import Runner
from hapticgraph.studio.adapter import body_carry

SHEET = """
hapticgraph: 1
rate: 44100
blocks:
  plate: {{type: lattice, shape: [6, 9], mass: 0.001, tension: 20000.0{extra}}}
  hit:   {{type: pluck, time: 0.0, force: 1.0, duration: 0.0005}}
  out:   {{type: audio_out}}
connect:
  - hit.out -> plate[2, 3].force
  - plate[4, 6].position -> out.left
"""


@pytest.mark.parametrize("old_editable,new_editable", [(False, False), (False, True), (True, False)])
def test_a_swapped_body_keeps_its_motion(write_patch, old_editable, new_editable):
    old = Runner(load(write_patch(SHEET.format(extra=""), name="a.yaml")), editable=old_editable)
    old.process(300)
    new = Runner(load(write_patch(SHEET.format(extra=", damping: 0.001"), name="b.yaml")), editable=new_editable)
    assert (new.prog.group_of["plate"].group.stencil is None) == new_editable
    before = old.prog.points("plate")
    x, v = before.positions.copy(), before.velocities.copy()
    assert np.max(np.abs(v)) > 0
    pairs = body_carry(old.prog, new.prog, kept=set())
    old.process(1)                               # the carry reads the old cells when it copies
    x1, v1 = old.prog.points("plate").positions.copy(), old.prog.points("plate").velocities.copy()
    assert not np.array_equal(x1, x)
    for dst, src in pairs:
        np.copyto(dst, src)
    after = new.prog.points("plate")
    # a velocity that crosses between the two kinds of storage is x − v·dt one way, (x − p)·fs
    # the other: rounding of a difference of two positions, far below 1e-6 of the motion
    np.testing.assert_array_equal(after.positions, x1)
    np.testing.assert_allclose(after.velocities, v1, rtol=0, atol=1e-6 * np.max(np.abs(v1)))
