#!/usr/bin/env python
"""Which ways of writing the one-pass 2-D leapfrog does numba vectorise, and how fast is each?
(issue 25, item 3: a prototype for the stencils' rewrite; blocks/massspring/ is not touched)

    python benchmarks/stencil_shapes.py [--reps 5] [--seconds 0.2]

The same step, x_new = A·x − B·x_old + C·(Σ 4 neighbours), written into the older buffer, the two
buffers swapped each step (the loop over steps inside one njit function, so no call overhead), on
a rows × cols lattice with a fixed boundary, in the shapes a kernel could take:
- flat:        one flat array per buffer, `i = r * cols + j`, `x[i - cols]` ... (a signed index:
               numba adds its negative-index wraparound to every access);
- flat_uint:   the same with the index cast to np.uint64 (no wraparound: an unsigned index);
- row_views:   per interior row, views of the rows above, at and below, indexed from 1;
- padded_run:  each buffer (rows+2) × (cols+2) with a ghost border, flattened; all interior rows
               as ONE run of views one row apart (as _sheet_bulk does), the ghost cells between
               rows (which the run overwrites) set back to 0 after each step;
- array_2d:    2-D arrays with a ghost border, `x[r - 1, j]` ...
Each is checked with benchmarks/vectorised.py's loop analysis (the optimised LLVM IR) and against
array_2d's result (bit for bit where the arithmetic is the same). Steps/s best of --reps.
"""
import argparse
import sys
import time

import numpy as np
from numba import njit

import vectorised

A, B, C = 1.8, 0.999, 0.05


@njit
def flat(x, xo, rows, cols, steps):
    for _ in range(steps):
        for r in range(1, rows - 1):
            for j in range(1, cols - 1):
                i = r * cols + j
                xo[i] = A * x[i] - B * xo[i] + C * ((x[i - cols] + x[i + cols]) + (x[i - 1] + x[i + 1]))
        x, xo = xo, x
    return x


@njit
def flat_uint(x, xo, rows, cols, steps):
    one, w = np.uint64(1), np.uint64(cols)
    for _ in range(steps):
        for r in range(1, rows - 1):
            for j in range(1, cols - 1):
                i = np.uint64(r * cols + j)
                xo[i] = A * x[i] - B * xo[i] + C * ((x[i - w] + x[i + w]) + (x[i - one] + x[i + one]))
        x, xo = xo, x
    return x


@njit
def _run(up, mid, down, out):
    for j in range(1, mid.shape[0] - 1):
        out[j] = A * mid[j] - B * out[j] + C * ((up[j] + down[j]) + (mid[j - 1] + mid[j + 1]))


@njit
def row_views(x, xo, rows, cols, steps):
    for _ in range(steps):
        for r in range(1, rows - 1):
            lo = r * cols
            _run(x[lo - cols:lo], x[lo:lo + cols], x[lo + cols:lo + 2 * cols], xo[lo:lo + cols])
        x, xo = xo, x
    return x


@njit
def padded_run(x, xo, rows, cols, steps):
    n = rows * cols
    for _ in range(steps):
        _run(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], xo[cols:n - cols])
        for r in range(1, rows - 1):             # the ghost columns the run wrote across
            xo[r * cols] = 0.0
            xo[r * cols + cols - 1] = 0.0
        x, xo = xo, x
    return x


@njit
def array_2d(x, xo, steps):
    rows, cols = x.shape
    for _ in range(steps):
        for r in range(1, rows - 1):
            for j in range(1, cols - 1):
                xo[r, j] = A * x[r, j] - B * xo[r, j] + C * ((x[r - 1, j] + x[r + 1, j]) + (x[r, j - 1] + x[r, j + 1]))
        x, xo = xo, x
    return x


def start(n):
    """(x, x_old) of an n × n lattice inside a ghost border, as 2-D arrays."""
    rng = np.random.default_rng(3)
    x, xo = np.zeros((n + 2, n + 2)), np.zeros((n + 2, n + 2))
    x[1:-1, 1:-1] = rng.uniform(-1e-3, 1e-3, (n, n))
    xo[1:-1, 1:-1] = x[1:-1, 1:-1] * 0.999
    return x, xo


def call(name, fn, n, steps):
    x, xo = start(n)
    if name == "array_2d":
        return fn(x, xo, steps)
    return fn(x.ravel(), xo.ravel(), n + 2, n + 2, steps).reshape(n + 2, n + 2)


def measure(n, reps, seconds):
    shapes = [("flat", flat), ("flat_uint", flat_uint), ("row_views", row_views), ("padded_run", padded_run),
              ("array_2d", array_2d)]
    reference = call("array_2d", array_2d, n, 50)
    for name, fn in shapes:
        got = call(name, fn, n, 50)
        sig = fn.signatures[0]
        loops = vectorised.kernel_loops(fn.inspect_llvm(sig), fn.overloads[sig].fndesc.mangled_name)
        vec = any(vectorised.is_interior(lp, 2) for lp in loops)
        t0 = time.perf_counter()
        call(name, fn, n, 100)
        steps = max(100, int(seconds / (time.perf_counter() - t0) * 100))
        best = min(_timed(name, fn, n, steps) for _ in range(reps))
        diff = float(np.max(np.abs(got - reference)))
        print(f"{n:>3} x {n:<3} {name:<11} vectorised {str(vec):<5} {steps / best:>12,.0f} steps/s"
              f"   |x - array_2d| {diff:.1e}")


def _timed(name, fn, n, steps):
    t0 = time.perf_counter()
    call(name, fn, n, steps)
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=0.2)
    args = ap.parse_args(argv)
    for n in (32, 150):
        measure(n, args.reps, args.seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
