#!/usr/bin/env python
"""What a uniform lattice's faces cost next to its vectorised interior, in bare numba.

    python benchmarks/stencil_edges.py [--reps 7] [--seconds 0.2]

hapticgraph's stencils (blocks/massspring/stencils.py, one pass: string, sheet and cube) run the interior of a lattice as
one vectorised run and its faces apart, with every boundary test, the interior run's first and last
columns set aside before it and put back after. Here, with the loop over steps inside one njit
function and the two buffers swapped each step (no kernel around it):
- stencil:   the real `string_step` / `sheet_step` (no driven cell, fixed boundary);
- interior:  only the interior run of the same arithmetic over the same flat buffers (the faces
             not computed: not a whole step, the floor the faces are measured against);
- rows:      a whole step over the same flat buffers: each interior row's inner cells as a loop
             over unsigned indices (numba adds no wraparound test: vectorised), so nothing is set
             aside, then the perimeter with its tests;
- peeled:    as rows, the perimeter peeled into loops without tests (the first and last rows as
             runs over views, the side columns as strided loops, the four corners alone);
- saved:     the stencil's structure (one run over the interior rows), but only the side
             columns' x[n−1] set aside (copied), those columns recomputed after the run without
             tests, the first and last rows as runs over views, the corners alone;
- padded:    a whole step over buffers with a ghost border of zeros ((rows+2) × (cols+2)), the
             interior rows as one run and the ghost cells it writes between rows zeroed after,
             the same arithmetic: what a padded layout would cost (the cube likewise: every
             interior plane in one run, its ghost rows and columns zeroed after).
Steps/s, best of --reps, the contenders interleaved; the faces' share = 1 − stencil/interior speeds. stencil and padded
are compared after 40 steps (they differ in rounding only: the faces sum their neighbours in
another order).
"""
import argparse
import sys
import time

import numpy as np
from numba import njit

from hapticgraph.blocks.massspring.stencils import cube_step, sheet_step, string_step
from hapticgraph.blocks.vocabulary import register_helpers

INV_MASS, TENSION, DAMPING, DT = 1000.0, 100000.0, 0.0001, 1.0 / 44100


def coefficients():
    w = DT * INV_MASS
    return 1.0 - w * DAMPING, DT * w * TENSION


@njit
def _run(up, mid, down, old, a, b):
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        old[j] = xj + a * (xj - old[j]) + b * (((up[j] + down[j]) + (mid[j - 1] + mid[j + 1])) - 4.0 * xj)


@njit
def _line(x, old, a, b):
    for i in range(1, x.shape[0] - 1):
        xi = x[i]
        old[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi)


@njit
def sheet_stencil(x, old, rows, cols, steps):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        sheet_step(x, old, frc, drv, rows, cols, INV_MASS, TENSION, DAMPING, DT, True)
        x, old = old, x
    return x


@njit
def sheet_interior(x, old, rows, cols, steps):
    a, b = coefficients_jit()
    n = rows * cols
    for _ in range(steps):
        _run(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], old[cols:n - cols], a, b)
        x, old = old, x
    return x


@njit
def sheet_padded(x, old, rows, cols, steps):
    """rows and cols of the padded buffers (the lattice's + 2)."""
    a, b = coefficients_jit()
    n = rows * cols
    for _ in range(steps):
        _run(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], old[cols:n - cols], a, b)
        for r in range(1, rows - 1):
            old[r * cols] = 0.0
            old[r * cols + cols - 1] = 0.0
        x, old = old, x
    return x


@njit
def _cell(x, old, r, j, rows, cols, a, b):
    """x[n+1] of a fixed-boundary cell with every boundary test (a missing neighbour: 0)."""
    i = r * cols + j
    s = 0.0
    if r > 0:
        s += x[i - cols]
    if r < rows - 1:
        s += x[i + cols]
    if j > 0:
        s += x[i - 1]
    if j < cols - 1:
        s += x[i + 1]
    xi = x[i]
    return xi + a * (xi - old[i]) + b * (s - 4.0 * xi)


@njit
def sheet_rows(x, old, rows, cols, steps):
    """Each interior row's cells 1 … cols−2 as a loop over unsigned indices (no wraparound test,
    vectorised, nothing set aside), then the perimeter, every cell with its tests."""
    a, b = coefficients_jit()
    one, w = np.uint64(1), np.uint64(cols)
    for _ in range(steps):
        for r in range(1, rows - 1):
            base = r * cols
            for j in range(1, cols - 1):
                i = np.uint64(base + j)
                xi = x[i]
                old[i] = xi + a * (xi - old[i]) + b * (((x[i - w] + x[i + w]) + (x[i - one] + x[i + one])) - 4.0 * xi)
        for j in range(cols):
            old[j] = _cell(x, old, 0, j, rows, cols, a, b)
            old[(rows - 1) * cols + j] = _cell(x, old, rows - 1, j, rows, cols, a, b)
        for r in range(1, rows - 1):
            old[r * cols] = _cell(x, old, r, 0, rows, cols, a, b)
            old[r * cols + cols - 1] = _cell(x, old, r, cols - 1, rows, cols, a, b)
        x, old = old, x
    return x


@njit
def _edge_row(near, mid, old, a, b):
    """Cells 1 … cols−2 of the first or last row: one neighbouring row (`near`), the other a ghost at 0."""
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        old[j] = xj + a * (xj - old[j]) + b * ((near[j] + (mid[j - 1] + mid[j + 1])) - 4.0 * xj)


@njit
def sheet_peeled(x, old, rows, cols, steps):
    """As sheet_rows, with the perimeter peeled into loops without tests: the first and last rows as
    runs over views (vectorised), the first and last columns as strided loops, the corners alone."""
    a, b = coefficients_jit()
    one, w = np.uint64(1), np.uint64(cols)
    n = rows * cols
    for _ in range(steps):
        for r in range(1, rows - 1):
            base = r * cols
            for j in range(1, cols - 1):
                i = np.uint64(base + j)
                xi = x[i]
                old[i] = xi + a * (xi - old[i]) + b * (((x[i - w] + x[i + w]) + (x[i - one] + x[i + one])) - 4.0 * xi)
        _edge_row(x[cols:2 * cols], x[:cols], old[:cols], a, b)
        _edge_row(x[n - 2 * cols:n - cols], x[n - cols:], old[n - cols:], a, b)
        for r in range(1, rows - 1):
            i = r * cols
            xi = x[i]
            old[i] = xi + a * (xi - old[i]) + b * (((x[i - cols] + x[i + cols]) + x[i + 1]) - 4.0 * xi)
            i += cols - 1
            xi = x[i]
            old[i] = xi + a * (xi - old[i]) + b * (((x[i - cols] + x[i + cols]) + x[i - 1]) - 4.0 * xi)
        for r in (0, rows - 1):
            for j in (0, cols - 1):
                old[r * cols + j] = _cell(x, old, r, j, rows, cols, a, b)
        x, old = old, x
    return x


@njit
def sheet_saved(x, old, rows, cols, steps):
    """The stencil's structure (ONE run over the interior rows, its first and last columns wrong),
    but what is set aside is only those columns' x[n−1], copied into frc (no tests, no arithmetic);
    after the run they are recomputed from it by strided loops without tests, the first and last
    rows by runs over views (vectorised) and the corners alone."""
    a, b = coefficients_jit()
    n = rows * cols
    frc = np.zeros(n)
    for _ in range(steps):
        for r in range(1, rows - 1):
            frc[r * cols] = old[r * cols]
            frc[r * cols + cols - 1] = old[r * cols + cols - 1]
        _run(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], old[cols:n - cols], a, b)
        for r in range(1, rows - 1):
            i = r * cols
            xi = x[i]
            old[i] = xi + a * (xi - frc[i]) + b * (((x[i - cols] + x[i + cols]) + x[i + 1]) - 4.0 * xi)
            frc[i] = 0.0
            i += cols - 1
            xi = x[i]
            old[i] = xi + a * (xi - frc[i]) + b * (((x[i - cols] + x[i + cols]) + x[i - 1]) - 4.0 * xi)
            frc[i] = 0.0
        _edge_row(x[cols:2 * cols], x[:cols], old[:cols], a, b)
        _edge_row(x[n - 2 * cols:n - cols], x[n - cols:], old[n - cols:], a, b)
        for r in (0, rows - 1):
            for j in (0, cols - 1):
                old[r * cols + j] = _cell(x, old, r, j, rows, cols, a, b)
        x, old = old, x
    return x


@njit
def string_stencil(x, old, rows, cols, steps):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        string_step(x, old, frc, drv, INV_MASS, TENSION, DAMPING, DT, True)
        x, old = old, x
    return x


@njit
def string_interior(x, old, rows, cols, steps):
    a, b = coefficients_jit()
    for _ in range(steps):
        _line(x, old, a, b)
        x, old = old, x
    return x


@njit
def _plane(back, up, mid, down, front, old, a, b):
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        s = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1])
        old[j] = xj + a * (xj - old[j]) + b * (s - 6.0 * xj)


@njit
def cube_stencil(x, old, rows, cols, steps):
    """rows: the planes × rows of the cube, flattened (a cube: planes = rows)."""
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        cube_step(x, old, frc, drv, cols, cols, cols, INV_MASS, TENSION, DAMPING, DT, True)
        x, old = old, x
    return x


@njit
def cube_interior(x, old, rows, cols, steps):
    """Only the runs over the interior rows of each interior plane, as cube_step makes them."""
    a, b = coefficients_jit()
    s0 = cols * cols
    for _ in range(steps):
        for p in range(1, cols - 1):
            lo = p * s0 + cols
            hi = lo + (cols - 2) * cols
            _plane(x[lo - s0:hi - s0], x[lo - cols:hi - cols], x[lo:hi], x[lo + cols:hi + cols],
                   x[lo + s0:hi + s0], old[lo:hi], a, b)
        x, old = old, x
    return x


@njit
def cube_padded(x, old, rows, cols, steps):
    """A whole step of a cube inside a ghost border ((n+2)³): every interior plane as ONE run, the
    ghost rows and columns it writes across zeroed after."""
    a, b = coefficients_jit()
    s0 = cols * cols
    lo, hi = s0, s0 * (cols - 1)                              # planes 1 … n, ghosts included
    for _ in range(steps):
        _plane(x[lo - s0:hi - s0], x[lo - cols:hi - cols], x[lo:hi], x[lo + cols:hi + cols],
               x[lo + s0:hi + s0], old[lo:hi], a, b)
        for p in range(1, cols - 1):
            base = p * s0
            for j in range(cols):
                old[base + j] = 0.0
                old[base + s0 - cols + j] = 0.0
            for r in range(1, cols - 1):
                old[base + r * cols] = 0.0
                old[base + r * cols + cols - 1] = 0.0
        x, old = old, x
    return x


coefficients_jit = njit(coefficients)


def start(shape, pad):
    rng = np.random.default_rng(7)
    full = tuple(s + 2 * pad for s in shape)
    x, old = np.zeros(full), np.zeros(full)
    inner = tuple(slice(pad, s + pad) for s in shape)
    x[inner] = rng.uniform(-1e-3, 1e-3, shape)
    old[inner] = x[inner] * 0.999
    return x, old


def run(fn, shape, pad, steps):
    x, old = start(shape, pad)
    rows, cols = (int(np.prod(x.shape[:-1])), x.shape[-1]) if len(shape) > 1 else (1, x.shape[0])
    t0 = time.perf_counter()
    out = fn(x.ravel(), old.ravel(), rows, cols, steps)
    return time.perf_counter() - t0, out.reshape(x.shape)


def case(label, shape, contenders, reps, seconds):
    """Each contender's steps/s, best of reps, the contenders interleaved rep by rep."""
    steps, outs = {}, {}
    for name, fn, pad in contenders:
        run(fn, shape, pad, 50)
        t, _ = run(fn, shape, pad, 50)
        steps[name] = max(50, int(seconds / max(t, 1e-9) * 50))
        outs[name] = run(fn, shape, pad, 40)[1]
    rates = {name: 0.0 for name, _, _ in contenders}
    for _ in range(reps):
        for name, fn, pad in contenders:
            rates[name] = max(rates[name], steps[name] / run(fn, shape, pad, steps[name])[0])
    same = ""
    if "padded" in outs:
        ref = outs["stencil"]
        inner = tuple(slice(1, -1) for _ in shape)
        worst = max(np.max(np.abs(ref - outs[name][inner if name == "padded" else ...])) for name in outs
                    if name != "interior")
        same = f"   |stencil - others| {worst / np.max(np.abs(ref)):.0e} of peak"
    share = 1.0 - rates["stencil"] / rates["interior"]
    print(f"{label:<16} " + "   ".join(f"{k} {v:>11,.0f}" for k, v in rates.items())
          + f"  steps/s   faces' share of the stencil {share:.0%}" + same)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--seconds", type=float, default=0.2)
    args = ap.parse_args(argv)
    register_helpers()
    case("string 30000", (30000,), [("stencil", string_stencil, 0), ("interior", string_interior, 0)],
         args.reps, args.seconds)
    for n in (32, 150):
        case(f"sheet {n} x {n}", (n, n), [("stencil", sheet_stencil, 0), ("interior", sheet_interior, 0),
                                          ("rows", sheet_rows, 0), ("peeled", sheet_peeled, 0),
                                          ("saved", sheet_saved, 0),
                                          ("padded", sheet_padded, 1)], args.reps, args.seconds)
    case("cube 20 x 20 x 20", (20, 20, 20), [("stencil", cube_stencil, 0), ("interior", cube_interior, 0),
                                             ("padded", cube_padded, 1)], args.reps, args.seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
