"""Predicted modal frequencies of a patch's mass-spring networks (`hapticgraph modes`).

For each fused network (graph.network.group / Network: lattices, cells and the springs that join
them) the undamped modes solve the generalized eigenproblem

    K φ = ω_c² M φ          (K: stiffness matrix, M: diagonal masses)

with the locked cells removed (a locked cell never moves, so it only anchors its neighbours:
its springs stay on their diagonals). The matrix is made symmetric with M^-½ K M^-½; a small
network (≤ DENSE_MAX movable cells) is solved densely (scipy.linalg.eigh), a larger one with
ARPACK in shift-invert mode around a small negative shift (scipy.sparse.linalg.eigsh,
sigma < 0: K − σM is positive definite even when the network floats freely, so the factorisation
never meets a singular matrix and the modes nearest 0 converge first).

Discrete time. The kernel integrates with the half-step (leapfrog) scheme, which for a mode of
x'' = −ω_c² x is exactly the recurrence

    x[n+1] − 2x[n] + x[n−1] = −dt²·ω_c²·x[n].

With x[n] = e^{iω_d n dt}: 2 − 2cos(ω_d dt) = dt²ω_c², i.e. sin(ω_d dt/2) = ω_c dt/2, so the mode
sounds at

    f_d = (fs/π)·asin(ω_c/(2·fs))

(always a little above ω_c/2π; the scheme is stable while ω_c·dt < 2, which the load-time check
dt²·Σk/m < 2 guarantees through Gershgorin's bound ω_c² ≤ 2·max Σk/m). A mode past that limit
would grow without bound: its frequency is reported as NaN.

What is ignored, and said so: damping (the modes are those of the lossless network; viscous
damping γ lowers a mode by about a factor √(1 − (γ/2mω)²)), external blocks coupled to cells
(bows, junctions, couplers) and live inputs — each component's `mass`, `tension` and `damping`
are taken at their patch values even when a connection drives them (a note says so).

Free networks. A network with no anchor (free boundary, no locked cell, no fixed lattice edge)
has rigid-body modes at ω = 0: they are REPORTED as 0 Hz modes, first in the list, and counted in
`rigid`, so the count of modes asked for includes them.
"""
import math
import os

import numpy as np

from ..blocks.family import LinearGroup
from .family import groups

DENSE_MAX = 800           # movable cells up to which the dense solver is always used
RIGID_TOL = 1e-12         # ω_c² below this fraction of the largest diagonal of M^-½KM^-½: a rigid mode (roundoff: ~1e-16)
# bytes the solver's own arrays may take (the dense matrix and LAPACK's copy, or ARPACK's Lanczos
# basis): with the interpreter and libraries (~150 MB) a solve stays under 1 GB (docs/limits.md)
MEMORY_BUDGET = 768 << 20
RESTARTS = 10             # ARPACK restarts assumed when comparing the cost of the two solvers
ARPACK_TOL = 1e-10        # relative accuracy of each eigenvalue (0.2 % is asked; round-off is reached)


class BudgetError(ValueError):
    """A count of modes whose solve would pass MEMORY_BUDGET; the message names the largest that fits."""


def _ncv(n, count):
    """ARPACK's Lanczos vectors for `count` modes of an n × n problem (scipy's rule, at most n)."""
    return min(n, max(2 * count + 1, count + 20))


def solver_plan(n, nnz, count, vectors=0):
    """(method, Lanczos vectors, bytes) to find the `count` lowest eigenvalues of an n × n sparse
    symmetric matrix with nnz entries (and `vectors` eigenvectors): "dense" (LAPACK on the full
    matrix, 8·n² bytes twice, ~4/3·n³ flops) or "shift-invert" (ARPACK on (A − σI)⁻¹, one sparse
    LU and ncv Lanczos vectors of n, ~RESTARTS·ncv·(4·n·ncv + 40·nnz) flops), the cheaper of those
    that fit MEMORY_BUDGET. BudgetError naming the largest count that fits if neither does."""
    dense_bytes = 16 * n * n + 8 * n * vectors
    dense_flops = 4 * n ** 3 / 3
    ncv = _ncv(n, count)
    sparse_bytes = 8 * n * (ncv + 10) + 8 * ncv * ncv
    sparse_flops = RESTARTS * ncv * (4 * n * ncv + 40 * nnz)
    can_sparse = n > DENSE_MAX and count < n - 1 and sparse_bytes <= MEMORY_BUDGET
    can_dense = n <= DENSE_MAX or dense_bytes <= MEMORY_BUDGET
    if can_sparse and (not can_dense or sparse_flops < dense_flops):
        return "shift-invert", ncv, sparse_bytes
    if can_dense:
        return "dense", 0, dense_bytes
    largest = _largest_sparse(n)
    raise BudgetError(f"{count:,} modes of a network of {n:,} movable cells take {_gb(min(dense_bytes, sparse_bytes))} "
                     f"to solve, over the {_gb(MEMORY_BUDGET)} modes may use (docs/limits.md); "
                     f"at most {largest:,} fit")


def _largest_sparse(n):
    """The largest count the sparse solver can find in MEMORY_BUDGET for n movable cells."""
    lo, hi = 0, n - 2
    while lo < hi:                    # ARPACK's memory grows with the count: bisect
        mid = (lo + hi + 1) // 2
        ncv = _ncv(n, mid)
        if 8 * n * (ncv + 10) + 8 * ncv * ncv <= MEMORY_BUDGET:
            lo = mid
        else:
            hi = mid - 1
    return lo


def _gb(nbytes):
    return f"{nbytes / 1e9:.2g} GB" if nbytes >= 1e8 else f"{nbytes / 1e6:.0f} MB"


def discrete_frequency(omega_c, rate):
    """f_d [Hz] of a continuous angular frequency ω_c [rad/s] under the half-step scheme at `rate`:
    (fs/π)·asin(ω_c/(2 fs)); NaN past the stability limit ω_c/(2 fs) > 1."""
    omega_c = np.asarray(omega_c, dtype=np.float64)
    s = omega_c / (2.0 * rate)
    with np.errstate(invalid="ignore"):
        return np.where(s <= 1.0, rate / math.pi * np.arcsin(np.minimum(s, 1.0)), np.nan)


class NetworkModes:
    """The modes of one network.

    name: the member names joined by ' + '; members, springs: block names; cells: movable cells
    (locked ones excluded); locked: number of locked cells; rigid: number of 0 Hz (rigid-body)
    modes reported; continuous: ω_c/2π [Hz]; frequencies: the half-step scheme's f_d [Hz];
    notes: what the prediction leaves out for this network.
    """

    def __init__(self, name, members, springs, cells, locked, continuous, frequencies, rigid, notes, method):
        self.name, self.members, self.springs = name, members, springs
        self.cells, self.locked = cells, locked
        self.continuous, self.frequencies = continuous, frequencies
        self.rigid, self.notes, self.method = rigid, notes, method

    def as_dict(self):
        return {"name": self.name, "members": self.members, "springs": self.springs, "cells": self.cells,
                "locked": self.locked, "rigid": self.rigid, "method": self.method,
                "frequencies": [None if math.isnan(f) else f for f in self.frequencies],
                "continuous": list(self.continuous), "notes": list(self.notes)}


def _mass_weighted(net):
    """(A = M^-½ K M^-½ of the movable cells as scipy.sparse CSC, exactly symmetric; the movable
    cells' indices; their masses). Built sparse: never an n × n array."""
    import scipy.sparse as sp
    mass = net.masses()
    idx = np.nonzero(np.isfinite(mass))[0]
    k = net.stiffness_matrix()[idx][:, idx]
    d = sp.diags(1.0 / np.sqrt(mass[idx]))
    a = (d @ k @ d).tocsc()
    return (0.5 * (a + a.T)).tocsc(), idx, mass[idx]


def _lowest(a, count, method, vectors=False, last=False):
    """The `count` lowest eigenvalues of the symmetric sparse `a` (ascending), and their
    eigenvectors (columns) if asked, by `method` ("dense" or "shift-invert"); with `last`, the
    dense solver finds only the count-th (the sparse one finds them all and keeps them all)."""
    n = a.shape[0]
    if method == "dense":
        import scipy.linalg as la
        out = la.eigh(a.toarray(), eigvals_only=not vectors, subset_by_index=[count - 1 if last else 0, count - 1],
                      overwrite_a=True, check_finite=False)
        return out if vectors else (out, None)
    import scipy.sparse as sp
    from scipy.sparse.linalg import LinearOperator, eigsh, splu
    scale = float(np.max(np.abs(a.diagonal())))
    sigma = -1e-6 * scale           # K − σM positive definite even for a free network: LU never singular
    lu = splu((a - sigma * sp.identity(n, format="csc")).tocsc(), permc_spec="MMD_AT_PLUS_A")  # symmetric: less fill
    inverse = LinearOperator((n, n), matvec=lu.solve, dtype=np.float64)
    out = eigsh(a, k=count, sigma=sigma, which="LM", OPinv=inverse, return_eigenvectors=vectors,
                tol=ARPACK_TOL, ncv=_ncv(n, count))
    lam, vec = out if vectors else (out, None)
    order = np.argsort(lam)
    return lam[order], (vec[:, order] if vectors else None)


def eigen_omegas(net, count, method=None):
    """The `count` smallest ω_c [rad/s] of a Network (locked cells removed), ascending, and the
    method used ("dense" | "shift-invert"; `method` forces one, else solver_plan chooses).
    BudgetError (naming the largest count that fits) when the solve would pass MEMORY_BUDGET."""
    a, idx, _ = _mass_weighted(net)
    n = len(idx)
    count = min(count, n)
    if count <= 0:
        return np.zeros(0), "none"
    scale = float(np.max(np.abs(a.diagonal())))
    if scale == 0.0:                          # no springs at all: every cell floats freely
        return np.zeros(count), "none"
    method = method or solver_plan(n, a.nnz, count)[0]
    lam, _ = _lowest(a, count, method)
    lam = np.sort(np.asarray(lam, dtype=np.float64))
    lam[np.abs(lam) < RIGID_TOL * scale] = 0.0
    return np.sqrt(np.maximum(lam, 0.0)), method


def _linear_groups(patch, editable=False):
    """(members, group) of every fused group with a linear model (a LinearGroup)."""
    for family, members in groups(patch.blocks):
        group = family.build(members, patch.rate, editable)
        if isinstance(group, LinearGroup):
            yield members, group


def mode_blocks(patch):
    """The blocks `mode_shape` can draw (the bodies of groups with a linear model), patch order."""
    return [name for _, net in _linear_groups(patch) for name in net.bodies()]


def network_modes(patch, count=20):
    """[NetworkModes] of every mass-spring network of a loaded patch, in patch order."""
    out = []
    connections = getattr(patch, "connections", ())
    for _, net in _linear_groups(patch):
        omegas, method = eigen_omegas(net, count)
        mass = net.masses()
        locked = int(np.sum(~np.isfinite(mass)))
        freqs = discrete_frequency(omegas, patch.rate)
        rigid = int(np.sum(omegas == 0.0))
        notes = net.notes(connections)
        if rigid:
            notes.append(f"{rigid} rigid-body mode(s) at 0 Hz (nothing anchors the network)")
        if np.any(np.isnan(freqs)):
            notes.append("modes marked nan exceed the half-step stability limit ω·dt < 2")
        out.append(NetworkModes(" + ".join(net.names), net.bodies(), net.links(),
                                net.n - locked, locked, [float(w / (2 * math.pi)) for w in omegas],
                                [float(f) for f in freqs], rigid, notes, method))
    return out


def modal_frequencies(patch, count=20):
    """{network name: [f_d in Hz, ascending]}: the `count` lowest modes of each mass-spring
    network of `patch` (a Patch or a path), with the half-step scheme's discrete-time correction;
    damping ignored; rigid-body modes of a free network reported as 0.0 Hz."""
    if isinstance(patch, (str, os.PathLike)):
        from .patch import load
        patch = load(patch)
    return {m.name: m.frequencies for m in network_modes(patch, count)}


def mode_shape(patch, lattice, mode=1):
    """(frequency in Hz, shape) of a network's mode `mode`, numbered from 1 as `hapticgraph modes`
    lists them (1: the lowest, rigid modes included), as seen on the lattice or cell block
    `lattice`: an array of its shape, the displacement of each cell (NaN for cut cells, 0 for
    locked ones), normalised to a peak of 1."""
    for members, net in _linear_groups(patch, editable=True):
        if lattice not in net.bodies():
            continue
        a, idx, mass = _mass_weighted(net)
        if mode < 1:
            raise ValueError(f"mode {mode} does not exist: modes are numbered from 1 (the lowest), "
                             f"as `hapticgraph modes` lists them")
        if mode > len(idx):
            raise ValueError(f"mode {mode} does not exist: the network of {lattice!r} has {len(idx)} "
                             f"movable cells, so modes 1 to {len(idx)}")
        method = solver_plan(len(idx), a.nnz, mode, vectors=1)[0]
        lam, vec = _lowest(a, mode, method, vectors=True, last=True)
        lam, vec = lam[-1:], vec[:, -1:]
        x = np.zeros(net.n)
        x[idx] = vec[:, 0] / np.sqrt(mass)          # back from mass-weighted coordinates
        peak = np.max(np.abs(x))
        if peak > 0:
            x /= x[np.argmax(np.abs(x))]
        freq = float(discrete_frequency(np.sqrt(max(lam[0], 0.0)), patch.rate))
        return freq, net.shape_of(lattice, x)
    raise ValueError(f"no lattice or cell block named {lattice!r}")
