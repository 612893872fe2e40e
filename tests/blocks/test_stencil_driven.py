"""The stencils read forces only at the driven cells (drv): the same numbers as a plain reference
that adds a force array into every cell each sample (the two-pass half-step update), for forces on
interior, edge and corner cells, both in Python (the interpreter's way) and compiled. The
stencils step in one pass (x[n+1] written over x[n−1], the two buffers then swapped, as the kernel
does), so this also checks that the one-pass recurrence is the half-step scheme."""
import numba
import numpy as np
import pytest
from hapticgraph.blocks.massspring import stencils
from hapticgraph.blocks.vocabulary import register_helpers


def reference(pos, vel, frc, shape, inv_mass, tension, damping, dt, fixed):
    """The half-step update with a force array read everywhere (numpy, neighbours up, down,
    left, right; a fixed boundary is a zero ghost cell, a free one no spring)."""
    x = pos.reshape(shape)
    f = np.zeros_like(x)
    for axis in range(x.ndim):
        for shift in (1, -1):
            nb = np.roll(x, shift, axis=axis)
            edge = [slice(None)] * x.ndim
            edge[axis] = 0 if shift == 1 else -1
            diff = nb - x
            diff[tuple(edge)] = -x[tuple(edge)] if fixed else 0.0
            f += diff
    vel += dt * inv_mass * (tension * f.ravel() + frc - damping * vel)
    frc[:] = 0.0
    pos += dt * vel


@pytest.mark.parametrize("shape,driven", [((9,), [0, 3, 4, 8]), ((1,), [0]), ((2,), [1]),
                                          ((5, 6), [0, 7, 8, 15, 29]), ((3, 1), [1]), ((1, 4), [2]),
                                          ((4, 5, 6), [0, 32, 36, 45, 77, 82, 119]), ((3, 3, 3), [13]),
                                          ((3, 3, 1), [4]), ((1, 4, 4), [5]), ((2, 3, 4), [17]), ((3, 1, 3), [4]),
                                          ((5, 4, 2), [10, 11]),
                                          # rows rounded up to a cache line (stencils.row_width: 39 → 40)
                                          ((3, 37), [0, 36, 37, 110]), ((2, 3, 37), [0, 40, 221])])
@pytest.mark.parametrize("fixed", [True, False])
@pytest.mark.parametrize("compiled", [False, True], ids=["python", "compiled"])
def test_stencil_reads_forces_only_where_driven(shape, driven, fixed, compiled):
    n = int(np.prod(shape))
    rng = np.random.default_rng(1)
    pos, vel = rng.normal(size=n) * 1e-3, rng.normal(size=n) * 1e-2
    ref_pos, ref_vel = pos.copy(), vel.copy()
    dt = 1 / 44100
    # the stencil's buffers: x[n] and x[n−1] (the one-pass form of v[n−½]) with a ghost border
    x, old, frc = (np.zeros(stencils.padded_size(shape)) for _ in range(3))
    inner = tuple(slice(1, 1 + s) for s in shape)
    cells = (lambda a: a.reshape(stencils.padded(shape))[inner])
    cells(x)[...] = pos.reshape(shape)
    cells(old)[...] = (pos - dt * vel).reshape(shape)
    ref_frc = np.zeros(n)
    drv = np.array([stencils.padded_index(shape, np.unravel_index(i, shape)) for i in driven], dtype=np.int64)
    args = (1000.0, 50.0, 0.02, dt, fixed)
    step = (stencils.string_step, stencils.sheet_step, stencils.cube_step)[len(shape) - 1]
    if compiled:
        register_helpers()
        step = numba.njit(step)
    for t in range(50):
        force = np.sin(0.3 * t + np.arange(len(driven)))
        frc[drv] += force
        ref_frc[driven] += force
        step(x, old, frc, drv, *(shape if len(shape) > 1 else ()), *args)
        x, old = old, x
        reference(ref_pos, ref_vel, ref_frc, shape, *args)
        assert not frc.any(), "the step must clear the forces it read"
    # rounding only: the reference sums in another order and keeps the velocity. 50 steps of
    # ~10 roundings each on |x| ~ 1e-3 stay far below 1e-12 of the peak; the velocity, a
    # difference of two positions ~ 1e-3 apart by ~ 2e-7, loses a factor |x|/|dt·v| ~ 5e3 of that.
    pos = cells(x).ravel()
    assert np.allclose(pos, ref_pos, rtol=1e-12, atol=1e-12 * np.abs(ref_pos).max())
    vel = (pos - cells(old).ravel()) / dt
    assert np.allclose(vel, ref_vel, rtol=1e-8, atol=1e-8 * np.abs(ref_vel).max())
