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

DENSE_MAX = 800           # movable cells up to which the dense solver is used
RIGID_TOL = 1e-12         # ω_c² below this fraction of the largest diagonal of M^-½KM^-½: a rigid mode (roundoff: ~1e-16)


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


def eigen_omegas(net, count):
    """The `count` smallest ω_c [rad/s] of a Network (locked cells removed), ascending, and the
    method used ("dense" | "shift-invert")."""
    import scipy.sparse as sp
    mass = net.masses()
    movable = np.isfinite(mass)
    idx = np.nonzero(movable)[0]
    n = len(idx)
    count = min(count, n)
    if count <= 0:
        return np.zeros(0), "none"
    k = net.stiffness_matrix()[idx][:, idx]
    d = sp.diags(1.0 / np.sqrt(mass[idx]))
    a = (d @ k @ d).tocsc()
    a = 0.5 * (a + a.T)                       # exactly symmetric
    scale = float(np.max(np.abs(a.diagonal()))) if n else 0.0
    if scale == 0.0:                          # no springs at all: every cell floats freely
        return np.zeros(count), "none"
    if n <= DENSE_MAX or count >= n - 1:
        import scipy.linalg as la
        lam = la.eigh(a.toarray(), eigvals_only=True, subset_by_index=[0, count - 1])
        method = "dense"
    else:
        from scipy.sparse.linalg import eigsh
        sigma = -1e-6 * scale
        lam = eigsh(a, k=count, sigma=sigma, which="LM", return_eigenvectors=False,
                    tol=1e-13, ncv=min(n, max(2 * count + 1, count + 20)))
        method = "shift-invert"
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
    import scipy.linalg as la
    import scipy.sparse as sp
    for members, net in _linear_groups(patch, editable=True):
        if lattice not in net.bodies():
            continue
        mass = net.masses()
        idx = np.nonzero(np.isfinite(mass))[0]
        if mode < 1:
            raise ValueError(f"mode {mode} does not exist: modes are numbered from 1 (the lowest), "
                             f"as `hapticgraph modes` lists them")
        if mode > len(idx):
            raise ValueError(f"mode {mode} does not exist: the network of {lattice!r} has {len(idx)} "
                             f"movable cells, so modes 1 to {len(idx)}")
        k = net.stiffness_matrix()[idx][:, idx]
        d = sp.diags(1.0 / np.sqrt(mass[idx]))
        a = (d @ k @ d).toarray()
        lam, vec = la.eigh(0.5 * (a + a.T), subset_by_index=[mode - 1, mode - 1])
        x = np.zeros(net.n)
        x[idx] = vec[:, 0] / np.sqrt(mass[idx])     # back from mass-weighted coordinates
        peak = np.max(np.abs(x))
        if peak > 0:
            x /= x[np.argmax(np.abs(x))]
        freq = float(discrete_frequency(np.sqrt(max(lam[0], 0.0)), patch.rate))
        return freq, net.shape_of(lattice, x)
    raise ValueError(f"no lattice or cell block named {lattice!r}")
