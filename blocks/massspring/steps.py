"""The per-sample steps of a fused mass-spring network with CSR spring lists: `network_step`
(the half-step scheme over every cell) and `points_step` (the points besides cells, first).

Integration is the half-step (leapfrog) scheme: velocities live half a sample ahead of positions,
    v[n+½] = v[n−½] + dt/m · (F_springs(x[n]) + F[n] − γ·v[n−½]),   x[n+1] = x[n] + dt·v[n+½],
stable while dt²·Σk/m + dt·γ/m < 2 for every cell (Gershgorin bound of the stiffness matrix).
A cell's `position` output is x[n], its `velocity` v[n−½]; its `force` input acts on v[n+½].
"""
from ..vocabulary import helper


def time_step(fs):
    """The step of a network at rate fs: dt = 1/fs [s]."""
    return 1.0 / fs


def per_second(fs):
    """What a change over one sample is multiplied by to be a rate of change: fs [1/s]."""
    return fs


@helper
def network_step(pos, vel, frc, inv_m, damp, anchor, cid, rowptr, col, kr, jrow, jcol, jk, scale, dt):
    """One half-step of a fused network with CSR spring lists (unsigned indices).

    Per cell i of component c = cid[i]: scale[c] = (1/mass, tension, damping) at this sample;
    inv_m and anchor are relative to the component (0 inverse mass: locked), damp is added to the
    component's damping (per-cell overrides). Springs inside
    components (rowptr/col/kr, scaled by the tension) and joins (jrow/jcol/jk, absolute).
    The cells are the first rowptr.shape[0] − 1 entries; pos and vel may hold extra points after
    them (ground, driven points, hammers: members.py), which this step leaves alone.
    """
    n = rowptr.shape[0] - 1
    for i in range(n):
        c = cid[i]
        xi = pos[i]
        f = 0.0
        for e in range(rowptr[i], rowptr[i + 1]):
            f += kr[e] * (pos[col[e]] - xi)
        f = scale[c, 1] * (f - anchor[i] * xi)
        for e in range(jrow[i], jrow[i + 1]):
            f += jk[e] * (pos[jcol[e]] - xi)
        w = inv_m[i] * scale[c, 0]
        vel[i] += dt * w * (f + frc[i] - (scale[c, 2] + damp[i]) * vel[i])
        frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def points_step(pos, vel, frc, rowptr, pt_slot, pt_in, dt):
    """The extra points before a step: forces on them cleared (a point's `force` output is what
    the links put there during the last step), each driven point moved to its input
    pt_in[j, 0] with the velocity of the move (pt_in[j, 1]: 1 once it has moved)."""
    n = rowptr.shape[0] - 1
    for i in range(n, pos.shape[0]):
        frc[i] = 0.0
    for j in range(pt_slot.shape[0]):
        i = pt_slot[j]
        x = pt_in[j, 0]
        if pt_in[j, 1] > 0.5:
            vel[i] = (x - pos[i]) / dt
        else:
            vel[i] = 0.0
            pt_in[j, 1] = 1.0
        pos[i] = x
