#!/usr/bin/env python
"""What a uniform lattice's faces cost now that its buffers have a ghost border, in bare numba.

    python benchmarks/stencil_edges.py [--reps 7] [--seconds 0.2]

hapticgraph's stencils (blocks/massspring/stencils.py: string, sheet and cube, one pass) keep a
lattice's two position buffers padded by one ghost cell on each side of every axis: every cell is
in ONE run without tests (vectorised), and each step first puts the ghosts right (0 for a fixed
boundary, the cell beside for a free one). Here, the loop over steps inside one njit function and
the two buffers swapped each step (no kernel around it), no driven cell:
- stencil:   the real `string_step` / `sheet_step` / `cube_step` on padded buffers;
- interior:  only the run of the same arithmetic over the same padded buffers (no ghosts put
             right, no driven cells looked at): not a whole step, the floor the faces are
             measured against;
- before:    the layout the ghost border replaced (blocks/massspring/stencils.py at 587ed16, copied
             below as it was): unpadded buffers, the interior run's first and last columns set aside
             into `frc` before it and put back after, the faces with every boundary test.
Steps/s, best of --reps, the three interleaved rep by rep. faces' share = 1 − stencil/interior;
speed-up = stencil/before. stencil and before must agree to rounding (they sum a face cell's
neighbours in another order): the lattice's cells after 40 steps within 1e-9 of the peak, or
exit status 1.
"""
import argparse
import sys
import time

import numpy as np
from numba import njit
from numba.extending import register_jitable

from hapticgraph.blocks.massspring.stencils import cube_step, sheet_step, string_step
from hapticgraph.blocks.vocabulary import register_helpers

INV_MASS, TENSION, DAMPING, DT = 1000.0, 100000.0, 0.0001, 1.0 / 44100
AGREE = 1e-9
CASES = (("string 30000", (30000,), True), ("sheet 32 x 32", (32, 32), True),
         ("sheet 32 x 32 free", (32, 32), False), ("sheet 150 x 150", (150, 150), True),
         ("cube 20 x 20 x 20", (20, 20, 20), True))


# ---- the runs alone (the same arithmetic as stencils.py's _line_run, _sheet_run, _cube_run) ----

@register_jitable
def _coefficients(inv_mass, tension, damping, dt):
    w = dt * inv_mass
    return 1.0 - w * damping, dt * w * tension, dt * w


@register_jitable
def _line(x, old, a, b):
    for i in range(1, x.shape[0] - 1):
        xi = x[i]
        old[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi)


@register_jitable
def _run(up, mid, down, old, a, b):
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        old[j] = xj + a * (xj - old[j]) + b * (((up[j] + down[j]) + (mid[j - 1] + mid[j + 1])) - 4.0 * xj)


@register_jitable
def _plane(back, up, mid, down, front, old, a, b):
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        s = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1])
        old[j] = xj + a * (xj - old[j]) + b * (s - 6.0 * xj)


# ---- before: blocks/massspring/stencils.py at 587ed16 (its bulk loops are _line, _run, _plane) ----

@register_jitable
def _side(s, k, x, i, step, lower, upper, fixed):
    if lower:
        s += x[i - step]
        k += 1.0
    elif fixed:
        k += 1.0
    if upper:
        s += x[i + step]
        k += 1.0
    elif fixed:
        k += 1.0
    return s, k


@register_jitable
def _next(x, old, frc, i, s, k, a, b, c):
    xi = x[i]
    return xi + a * (xi - old[i]) + b * (s - k * xi) + c * frc[i]


@register_jitable
def before_string_step(x, old, frc, drv, inv_mass, tension, damping, dt, fixed):
    n = x.shape[0]
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    for k in range(drv.shape[0]):
        i = drv[k]
        if 0 < i < n - 1:
            xi = x[i]
            frc[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi) + c * frc[i]
    _line(x, old, a, b)
    for k in range(drv.shape[0]):
        i = drv[k]
        if 0 < i < n - 1:
            old[i] = frc[i]
            frc[i] = 0.0
    for i in range(0, n, max(n - 1, 1)):
        s, k = _side(0.0, 0.0, x, i, 1, i > 0, i < n - 1, fixed)
        old[i] = _next(x, old, frc, i, s, k, a, b, c)
        frc[i] = 0.0


@register_jitable
def _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed):
    i = r * cols + col
    s, k = _side(0.0, 0.0, x, i, cols, r > 0, r < rows - 1, fixed)
    s, k = _side(s, k, x, i, 1, col > 0, col < cols - 1, fixed)
    return _next(x, old, frc, i, s, k, a, b, c)


@register_jitable
def _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, before):
    for r in range(1, rows - 1):
        for col in range(0, cols, max(cols - 1, 1)):
            i = r * cols + col
            if before:
                frc[i] = _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed)
            else:
                old[i] = frc[i]
                frc[i] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        r, col = i // cols, i % cols
        if r < 1 or r > rows - 2 or col < 1 or col > cols - 2:
            continue
        if before:
            xi = x[i]
            s = (x[i - cols] + x[i + cols]) + (x[i - 1] + x[i + 1])
            frc[i] = xi + a * (xi - old[i]) + b * (s - 4.0 * xi) + c * frc[i]
        else:
            old[i] = frc[i]
            frc[i] = 0.0


@register_jitable
def before_sheet_step(x, old, frc, drv, rows, cols, inv_mass, tension, damping, dt, fixed):
    n = rows * cols
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    if rows > 2:
        _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, True)
        _run(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], old[cols:n - cols], a, b)
        _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, False)
    for r in range(0, rows, max(rows - 1, 1)):
        for col in range(cols):
            i = r * cols + col
            old[i] = _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed)
            frc[i] = 0.0


@register_jitable
def _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed):
    s0 = rows * cols
    i = p * s0 + r * cols + col
    s, k = _side(0.0, 0.0, x, i, s0, p > 0, p < planes - 1, fixed)
    s, k = _side(s, k, x, i, cols, r > 0, r < rows - 1, fixed)
    s, k = _side(s, k, x, i, 1, col > 0, col < cols - 1, fixed)
    return _next(x, old, frc, i, s, k, a, b, c)


@register_jitable
def _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, before):
    for p in range(1, planes - 1):
        for r in range(1, rows - 1):
            for col in range(0, cols, max(cols - 1, 1)):
                i = (p * rows + r) * cols + col
                if before:
                    frc[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
                else:
                    old[i] = frc[i]
                    frc[i] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        p, rest = i // (rows * cols), i % (rows * cols)
        r, col = rest // cols, rest % cols
        if p < 1 or p > planes - 2 or r < 1 or r > rows - 2 or col < 1 or col > cols - 2:
            continue
        if before:
            frc[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
        else:
            old[i] = frc[i]
            frc[i] = 0.0


@register_jitable
def before_cube_step(x, old, frc, drv, planes, rows, cols, inv_mass, tension, damping, dt, fixed):
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    s0 = rows * cols
    bulk = planes > 2 and rows > 2
    if bulk:
        _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, True)
        for p in range(1, planes - 1):
            lo = p * s0 + cols
            hi = lo + (rows - 2) * cols
            _plane(x[lo - s0:hi - s0], x[lo - cols:hi - cols], x[lo:hi], x[lo + cols:hi + cols],
                   x[lo + s0:hi + s0], old[lo:hi], a, b)
        _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, False)
    for p in range(planes):
        face = not bulk or p == 0 or p == planes - 1
        for r in range(rows):
            if face or r == 0 or r == rows - 1:
                for col in range(cols):
                    i = (p * rows + r) * cols + col
                    old[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
                    frc[i] = 0.0


# ---- the contenders: (x, old, dims, steps, fixed) -> the positions after `steps` steps ----
# dims are the lattice's extents; x and old are flat, padded for stencil and interior.

@njit
def string_stencil(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        string_step(x, old, frc, drv, INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


@njit
def string_interior(x, old, dims, steps, fixed):
    a, b, _ = _coefficients(INV_MASS, TENSION, DAMPING, DT)
    for _ in range(steps):
        _line(x, old, a, b)
        x, old = old, x
    return x


@njit
def string_before(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        before_string_step(x, old, frc, drv, INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


@njit
def sheet_stencil(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        sheet_step(x, old, frc, drv, dims[0], dims[1], INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


@njit
def sheet_interior(x, old, dims, steps, fixed):
    """The run of sheet_step alone: rows 1 … rows of the padded buffers, whole."""
    a, b, _ = _coefficients(INV_MASS, TENSION, DAMPING, DT)
    width = dims[1] + 2
    lo, hi = width, (dims[0] + 1) * width
    for _ in range(steps):
        _run(x[lo - width:hi - width], x[lo:hi], x[lo + width:hi + width], old[lo:hi], a, b)
        x, old = old, x
    return x


@njit
def sheet_before(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        before_sheet_step(x, old, frc, drv, dims[0], dims[1], INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


@njit
def cube_stencil(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        cube_step(x, old, frc, drv, dims[0], dims[1], dims[2], INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


@njit
def cube_interior(x, old, dims, steps, fixed):
    """The run of cube_step alone: (1, 1, 0) … (planes, rows + 1, 0) of the padded buffers."""
    a, b, _ = _coefficients(INV_MASS, TENSION, DAMPING, DT)
    width, area = dims[2] + 2, (dims[1] + 2) * (dims[2] + 2)
    lo, hi = area + width, dims[0] * area + (dims[1] + 1) * width
    for _ in range(steps):
        _plane(x[lo - area:hi - area], x[lo - width:hi - width], x[lo:hi], x[lo + width:hi + width],
               x[lo + area:hi + area], old[lo:hi], a, b)
        x, old = old, x
    return x


@njit
def cube_before(x, old, dims, steps, fixed):
    frc, drv = np.zeros(x.shape[0]), np.zeros(0, dtype=np.int64)
    for _ in range(steps):
        before_cube_step(x, old, frc, drv, dims[0], dims[1], dims[2], INV_MASS, TENSION, DAMPING, DT, fixed)
        x, old = old, x
    return x


CONTENDERS = {1: (("stencil", string_stencil, 1), ("interior", string_interior, 1), ("before", string_before, 0)),
              2: (("stencil", sheet_stencil, 1), ("interior", sheet_interior, 1), ("before", sheet_before, 0)),
              3: (("stencil", cube_stencil, 1), ("interior", cube_interior, 1), ("before", cube_before, 0))}


def start(shape, pad):
    """x[n] and x[n−1]: the same random displacement whatever the layout (no subnormals), ghosts 0."""
    rng = np.random.default_rng(7)
    full = tuple(s + 2 * pad for s in shape)
    x, old = np.zeros(full), np.zeros(full)
    cells = tuple(slice(pad, s + pad) for s in shape)
    x[cells] = rng.uniform(-1e-3, 1e-3, shape)
    old[cells] = x[cells] * 0.999
    return x, old


def run(fn, shape, pad, steps, fixed):
    """(seconds, the lattice's cells after `steps` steps, ghosts left out)."""
    x, old = start(shape, pad)
    t0 = time.perf_counter()
    out = fn(x.ravel(), old.ravel(), tuple(shape), steps, fixed)
    seconds = time.perf_counter() - t0
    return seconds, out.reshape(x.shape)[tuple(slice(pad, s + pad) for s in shape)]


def case(shape, fixed, reps, seconds):
    """({contender: steps/s, best of reps, interleaved rep by rep}, |stencil − before| / peak)."""
    contenders = CONTENDERS[len(shape)]
    steps, outs = {}, {}
    for name, fn, pad in contenders:
        outs[name] = run(fn, shape, pad, 40, fixed)[1]           # compiles, and the check
        t = run(fn, shape, pad, 50, fixed)[0]
        steps[name] = max(50, int(seconds / max(t, 1e-9) * 50))
    rates = {name: 0.0 for name, _, _ in contenders}
    for _ in range(reps):
        for name, fn, pad in contenders:
            rates[name] = max(rates[name], steps[name] / run(fn, shape, pad, steps[name], fixed)[0])
    gap = np.max(np.abs(outs["stencil"] - outs["before"])) / np.max(np.abs(outs["before"]))
    return rates, gap


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--seconds", type=float, default=0.2)
    args = ap.parse_args(argv)
    register_helpers()
    print(f"{'lattice':<20}{'stencil':>12}{'interior':>12}{'before':>12}   steps/s   "
          f"faces' share   stencil/before   |stencil - before|/peak")
    worst = 0.0
    for label, shape, fixed in CASES:
        rates, gap = case(shape, fixed, args.reps, args.seconds)
        worst = max(worst, gap)
        share = 1.0 - rates["stencil"] / rates["interior"]
        print(f"{label:<20}" + "".join(f"{rates[k]:>12,.0f}" for k in ("stencil", "interior", "before"))
              + f"{'':>13}{share:>11.0%}{rates['stencil'] / rates['before']:>16.2f}x{gap:>21.0e}", flush=True)
    if not worst < AGREE:
        print(f"stencil and before disagree: {worst:.1e} of the peak (at most {AGREE:.0e})", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
