"""The stencils of a uniform lattice (no locks, cuts, overrides or joins): `string_step`,
`sheet_step` and `cube_step` step a 1-D, 2-D or 3-D lattice in ONE pass over its cells, without
the CSR lists of `network_step` (steps.py): so a 100,000-cell instrument is one loop.

They run the half-step scheme of steps.py with the velocity eliminated, v[n−½] = (x[n] − x[n−1])/dt:

    x[n+1] = x[n] + a·(x[n] − x[n−1]) + b·(Σ_neighbours x[n] − 2·D·x[n]) + c·F[n],
    a = 1 − dt·γ/m,   b = dt²·T/m,   c = dt²/m,   D the lattice's dimensions,

over cells padded with a ghost border (`padded`: a rows × cols sheet lives in (rows + 2) ×
row_width(cols) entries, row-major: cols + 2, or a little more so that each row starts on a
cache line): a fixed boundary's ghosts sit at 0 (the anchor spring), a free
one's copy the cell beside them (a spring that pulls nothing). So every cell has 2·D neighbours
and there is no boundary test: all cells are ONE run with no tests (vectorised), which also
writes into the ghost columns between rows (and rows between planes); each step first puts the
ghosts of its positions right (`_sheet_ghosts`, `_cube_ghosts`), a few cells per row.

The same recurrence as the half-step in exact arithmetic, so the same stability bound and the
same modes; only the rounding differs. It is written as increments (x[n] − x[n−1], Σ − 2D·x)
rather than as the FDTD's (2 − ...)·x[n] − x[n−1] + ...: that form rounds its diagonal once and
errs by the same eps·|x| every step, a drift a free lattice's rigid mode integrates (its momentum
off by 1e-9 after 0.2 s, against 1e-11 here), at the same speed.

Each step writes x[n+1] over x[n−1] (`old`) and the kernel then swaps the two buffers (the
group's rotation, graph/family.py), so the positions `x` are x[n] whenever a block reads them,
and a cell's velocity (x[n] − x[n−1])·fs is computed where it is read (a microphone, a probe, a
coupling), not stored. Forces are read only at the driven cells (`drv`, padded indices): after
the run, each one's x[n+1] gets its c·F[n] (`_drive`), which is the recurrence's last term.
"""
import math

import numpy as np

from ..vocabulary import helper

ALIGN = 64          # bytes: a cache line, and one 8-wide vector of doubles


@helper
def row_width(cols):
    """The extent of a padded row of a 2-D or 3-D lattice: cols and its two ghosts, rounded up to
    a multiple of 8 doubles (a cache line) when that adds at most 1/16 more entries, so every row
    of the run starts where the first does, on a line: a 100 × 100 sheet's run then takes 0.45
    instead of 0.53 ns a cell (bare numba, median of 7); a 32 × 32 one (34 → 40) would lose more
    to the 18 % more entries than it gains. The extra entries sit past the right ghost: the run
    computes them from their neighbours and nothing reads them (a fixed sheet's stay 0)."""
    width = cols + 2
    extra = (8 - width % 8) % 8
    return width + extra if 16 * extra <= width else width


def padded(shape):
    """The extents of a lattice's buffers: a ghost cell on each side of every axis (a 2-D or 3-D
    lattice's rows rounded up to row_width)."""
    extents = [int(s) + 2 for s in shape]
    if len(extents) >= 2:
        extents[-1] = row_width(int(shape[-1]))
    return tuple(extents)


def padded_index(shape, index):
    """The flat index of cell `index` in buffers of extents padded(shape)."""
    flat = 0
    for s, i in zip(padded(shape), index):
        flat = flat * s + int(i) + 1
    return flat


def padded_size(shape):
    return math.prod(padded(shape))


def padded_zeros(shape):
    """A zeroed buffer of padded_size(shape) doubles whose first cell (index (0, …, 0), where each
    run's first load and store fall) starts a cache line: LLVM does not peel a loop to align it,
    and 8-wide loads and stores that straddle two lines cost a 30,000-cell string's run 12-20 %
    (0.43 against 0.49-0.53 ns a cell, bare numba, the four alignments interleaved). A view of
    a slightly larger array, contiguous, so the kernel's types are the same."""
    size, first = padded_size(shape), padded_index(shape, (0,) * len(shape))
    raw = np.zeros(size + ALIGN // 8)
    skip = ((-(raw.ctypes.data + 8 * first)) % ALIGN) // 8
    return raw[skip:skip + size]


@helper
def _coefficients(inv_mass, tension, damping, dt):
    """(a, b, c) of the one-pass recurrence at this sample's mass, tension and damping."""
    w = dt * inv_mass
    return 1.0 - w * damping, dt * w * tension, dt * w


@helper
def _drive(old, frc, drv, c):
    """The forces on the driven cells, after the run: each one's x[n+1] gets c·F[n], and its
    force is cleared. The run computed x[n] + a·(x[n] − x[n−1]) + b·(Σ − 2D·x[n]) there as for
    any cell, so adding c·F last is the recurrence term for term, in its order: the same bits
    as computing the driven cell apart with its force (as this did before, at twice the cost
    of a cell every sample)."""
    for j in range(drv.shape[0]):
        i = drv[j]
        old[i] = old[i] + c * frc[i]
        frc[i] = 0.0


@helper
def _line_run(x, old, a, b):
    """Cells 1 … n of a padded string: no tests, vectorised."""
    for i in range(1, x.shape[0] - 1):
        xi = x[i]
        old[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi)


@helper
def string_step(x, old, frc, drv, inv_mass, tension, damping, dt, fixed):
    """The 1-D stencil over a padded string: x[n+1] of every cell into `old` (then swapped)."""
    n = x.shape[0] - 2
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    x[0] = 0.0 if fixed else x[1]
    x[n + 1] = 0.0 if fixed else x[n]
    _line_run(x, old, a, b)
    _drive(old, frc, drv, c)


@helper
def _sheet_ghosts(x, rows, cols, fixed):
    """A padded sheet's ghosts as the boundary has them: 0 (fixed), or the cell beside (free).
    The run wrote into the ghost columns; the ghost rows of a fixed sheet stay 0."""
    width = row_width(cols)
    for r in range(1, rows + 1):
        i = r * width
        x[i] = 0.0 if fixed else x[i + 1]
        x[i + cols + 1] = 0.0 if fixed else x[i + cols]
    if not fixed:
        last = (rows + 1) * width
        for col in range(width):
            x[col] = x[width + col]
            x[last + col] = x[last - width + col]


@helper
def _sheet_run(up, mid, down, old, a, b):
    """Every cell of a padded sheet as one run (the views start one row apart and are indexed
    from 1, so no index is negative: no wraparound test, no test at all: vectorised). It also
    writes into the ghost columns between rows, put right at the next step."""
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        old[j] = xj + a * (xj - old[j]) + b * (((up[j] + down[j]) + (mid[j - 1] + mid[j + 1])) - 4.0 * xj)


@helper
def sheet_step(x, old, frc, drv, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 2-D stencil over a padded rows × cols sheet: x[n+1] of every cell into `old`."""
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    width = row_width(cols)
    lo, hi = width, (rows + 1) * width                  # rows 1 … rows, whole
    _sheet_ghosts(x, rows, cols, fixed)
    _sheet_run(x[lo - width:hi - width], x[lo:hi], x[lo + width:hi + width], old[lo:hi], a, b)
    _drive(old, frc, drv, c)


@helper
def _cube_ghosts(x, planes, rows, cols, fixed):
    """A padded cube's ghosts as the boundary has them: 0 (fixed), or the cell beside (free).
    The run wrote into the ghost columns and the ghost rows of planes 1 … planes."""
    width = row_width(cols)
    area = (rows + 2) * width
    for p in range(1, planes + 1):
        base = p * area
        for col in range(width):                       # ghost rows 0 and rows + 1
            top, bottom = base + col, base + (rows + 1) * width + col
            x[top] = 0.0 if fixed else x[top + width]
            x[bottom] = 0.0 if fixed else x[bottom - width]
        for r in range(1, rows + 1):                    # ghost columns 0 and cols + 1
            i = base + r * width
            x[i] = 0.0 if fixed else x[i + 1]
            x[i + cols + 1] = 0.0 if fixed else x[i + cols]
    if not fixed:
        last = (planes + 1) * area
        for k in range(area):
            x[k] = x[area + k]
            x[last + k] = x[last - area + k]


@helper
def _cube_run(back, up, mid, down, front, old, a, b):
    """Every cell of a padded cube as one run (views one plane or one row apart, indexed from 1:
    no tests, vectorised); it also writes into ghost rows and columns, put right next step."""
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        s = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1])
        old[j] = xj + a * (xj - old[j]) + b * (s - 6.0 * xj)


@helper
def cube_step(x, old, frc, drv, planes, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 3-D stencil (the 7-point Laplacian) over a padded planes × rows × cols lattice."""
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    width = row_width(cols)
    area = (rows + 2) * width
    lo, hi = area + width, planes * area + (rows + 1) * width    # (1, 1, 0) … (planes, rows + 1, 0)
    _cube_ghosts(x, planes, rows, cols, fixed)
    _cube_run(x[lo - area:hi - area], x[lo - width:hi - width], x[lo:hi], x[lo + width:hi + width],
              x[lo + area:hi + area], old[lo:hi], a, b)
    _drive(old, frc, drv, c)
