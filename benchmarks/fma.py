#!/usr/bin/env python
"""Is fused multiply-add worth it for the one-pass leapfrog of a uniform lattice? (issue 25, item 2)

    python benchmarks/fma.py [--reps 9] [--seconds 0.25] [--quick]

Bare numba (plain @njit: no fast-math, float64), the stencil alone, no hapticgraph, in two forms:

    fdtd:       x_new[i] = A·x[i] − B·x_old[i] + C·(Σ neighbours of i)
    increment:  x_new[i] = x[i] + a·(x[i] − x_old[i]) + b·(Σ neighbours of i − k·x[i])
                (the form of blocks/massspring/stencils.py since the one-pass rewrite)

on a 30,000-cell string and on 32 × 32 and 150 × 150 sheets with a fixed boundary (a ghost border
of zeros around the cells), written into the older buffer, the two buffers swapped each step. Two
variants of each form:
- plain: as written above (numba's LLVM contracts nothing without fast-math);
- fma:   fdtd `fma(C, s, fma(A, x, -(B·x_old)))`, increment `fma(b, fma(−k, x, s), fma(a, x − x_old, x))`,
  fma an explicit `llvm.fma.f64` (numba's extension API, `numba.extending.intrinsic`): every
  product but one (fdtd) or all three (increment) rounded once with the sum it feeds.
The coefficients are those of the benchmark lattices (mass 1 g, tension 10⁵ N/m, damping 10⁻⁴, 44.1 kHz).

Each repetition starts both variants from the same random displacement (no subnormal numbers) and
runs the same number of steps (about --seconds each), the two interleaved (each goes first every
other time); steps/s is the best of --reps. Ratio = fma steps/s / plain steps/s (> 1: FMA is
faster): of the best runs, and the median and quartiles of the ratios of runs made side by side
(robust to a machine whose load changes during the run). The final states
of the two must agree within rounding: max |plain − fma| ≤ 1e-9 of the peak (they differ only in
where products are rounded; a wrong coefficient or neighbour gives 1e-4 or more). The machine code
is inspected too: the vector width of the loop and the count of packed FMA instructions, so a
figure is never that of a loop that did not vectorise. Exit status 1 if the variants disagree.
"""
import argparse
import datetime
import itertools
import platform
import re
import statistics
import sys
import time

import numpy as np
import benchlib

RATE, MASS, TENSION, DAMPING = 44100.0, 0.001, 100000.0, 0.0001
TOLERANCE = 1e-9            # of the peak displacement
CASES = [("string", (30000,)), ("sheet", (32, 32)), ("sheet", (150, 150))]
FORMS = ("fdtd", "increment")


def coefficients(form, dim):
    """The three coefficients of a form at the benchmark lattices' mass, tension and damping.
    fdtd: (A, B, C) of m·(x⁺ − 2x + x⁻)/dt² = T·Δx − R·(x⁺ − x⁻)/(2dt);
    increment: (a, b, k) of blocks/massspring/stencils.py, x⁺ = x + a·(x − x⁻) + b·(Σ − k·x)."""
    if form == "increment":
        w = 1.0 / (RATE * MASS)
        return 1.0 - w * DAMPING, w * TENSION / RATE, 2.0 * dim
    c2 = TENSION / MASS / RATE ** 2
    g = DAMPING / (2.0 * MASS * RATE)
    return (2.0 - 2.0 * dim * c2) / (1.0 + g), (1.0 - g) / (1.0 + g), c2 / (1.0 + g)


def fma_intrinsic():
    """fma(x, y, z): x·y + z rounded once, an explicit llvm.fma.f64 in numba's IR."""
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def fma(typingctx, x, y, z):
        """x·y + z rounded once: LLVM's llvm.fma.f64 (a vfmadd on a CPU with FMA, vectorisable)."""
        if not all(isinstance(t, types.Float) for t in (x, y, z)):
            return None

        def codegen(context, builder, signature, args):
            return builder.fma(*args)
        return types.float64(types.float64, types.float64, types.float64), codegen
    return fma


def make_kernels():
    """{(kind, form, variant): njit function(x, xo, p, q, r, steps) -> (newest, older)}: one step
    of each cell is cell(x, x_old, Σ neighbours, p, q, r); the fma variants fuse its products."""
    from numba import njit
    fma = fma_intrinsic()
    cells = {
        ("fdtd", "plain"): lambda xc, xp, s, p, q, r: p * xc - q * xp + r * s,
        ("fdtd", "fma"): lambda xc, xp, s, p, q, r: fma(r, s, fma(p, xc, -(q * xp))),
        ("increment", "plain"): lambda xc, xp, s, p, q, r: xc + p * (xc - xp) + q * (s - r * xc),
        ("increment", "fma"): lambda xc, xp, s, p, q, r: fma(q, fma(-r, xc, s), fma(p, xc - xp, xc)),
    }
    kernels = {}
    for (form, variant), cell in cells.items():
        string, sheet = _steppers(njit(cell))
        kernels[("string", form, variant)], kernels[("sheet", form, variant)] = string, sheet
    return kernels


def _steppers(cell):
    """(string, sheet) stepping loops around one cell's update (inlined by LLVM)."""
    from numba import njit

    @njit
    def string(x, xo, p, q, r, steps):
        n = x.shape[0]
        for _ in range(steps):
            for i in range(1, n - 1):
                xo[i] = cell(x[i], xo[i], x[i - 1] + x[i + 1], p, q, r)
            x, xo = xo, x
        return x, xo

    @njit
    def sheet(x, xo, p, q, r, steps):
        rows, cols = x.shape
        for _ in range(steps):
            for i in range(1, rows - 1):
                for j in range(1, cols - 1):
                    s = (x[i - 1, j] + x[i + 1, j]) + (x[i, j - 1] + x[i, j + 1])
                    xo[i, j] = cell(x[i, j], xo[i, j], s, p, q, r)
            x, xo = xo, x
        return x, xo
    return string, sheet


def initial(shape, seed=25):
    """(x, x_old): random cells inside a ghost border of zeros."""
    rng = np.random.default_rng(seed)
    x = np.zeros(tuple(s + 2 for s in shape))
    inner = tuple(slice(1, -1) for _ in shape)
    x[inner] = rng.uniform(-1e-3, 1e-3, shape)
    xo = x.copy()
    xo[inner] += rng.uniform(-1e-5, 1e-5, shape)
    return x, xo


def machine_code(fn):
    """(widest packed double register used in arithmetic, count of packed FMA instructions)."""
    asm = fn.inspect_asm(fn.signatures[0])
    widths = {"xmm": 2, "ymm": 4, "zmm": 8}
    packed = re.findall(r"\bv(?:add|sub|mul|fmadd\d*|fnmadd\d*|fmsub\d*)pd\s+%?([xyz]mm)", asm)
    fmas = re.findall(r"\bvf(?:n?madd|n?msub)\d*pd\b", asm)
    return max((widths[r] for r in packed), default=1), len(fmas)


def timed(fn, shape, coef, steps):
    """(seconds, final newest buffer) of `steps` steps from the initial state."""
    x, xo = initial(shape)
    start = time.perf_counter()
    new, _ = fn(x, xo, *coef, steps)
    return time.perf_counter() - start, new


def measure(kernels, kind, form, shape, reps, seconds):
    """One case: steps/s of each variant (best, median), and their disagreement."""
    coef = coefficients(form, len(shape))
    plain, fused = kernels[(kind, form, "plain")], kernels[(kind, form, "fma")]
    for fn in (plain, fused):
        timed(fn, shape, coef, 2)                        # compile and warm
    t, _ = timed(plain, shape, coef, 200)
    steps = max(200, int(seconds / t * 200))
    rates, last = {"plain": [], "fma": []}, {}
    for k in range(reps):
        pair = (("plain", plain), ("fma", fused))
        for name, fn in pair if k % 2 == 0 else pair[::-1]:        # either goes first as often
            t, last[name] = timed(fn, shape, coef, steps)
            rates[name].append(steps / t)
    diff = float(np.max(np.abs(last["fma"] - last["plain"])) / np.max(np.abs(last["plain"])))
    return {"steps": steps, "rates": rates, "diff": diff,
            "code": {name: machine_code(fn) for name, fn in (("plain", plain), ("fma", fused))}}


def report(kind, form, shape, m):
    cells = int(np.prod(shape))
    best = {k: max(v) for k, v in m["rates"].items()}
    paired = sorted(f / p for f, p in zip(m["rates"]["fma"], m["rates"]["plain"]))
    q1, med, q3 = statistics.quantiles(paired, n=4) if len(paired) > 1 else paired * 3
    label = f"{kind} {' x '.join(map(str, shape))} {form}"
    (wp, _), (wf, nf) = m["code"]["plain"], m["code"]["fma"]
    print(f"{label:<26} plain {best['plain']:>12,.0f} steps/s ({best['plain'] * cells / 1e9:.2f} G cells/s)"
          f"   fma {best['fma']:>12,.0f} steps/s   fma/plain: best {best['fma'] / best['plain']:.3f},"
          f" paired runs median {med:.3f} [{q1:.3f} … {q3:.3f}]   |diff| {m['diff']:.1e} of peak"
          f"   width plain {wp} fma {wf} ({nf} vfmadd)")
    return best["fma"] / best["plain"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=9)
    ap.add_argument("--seconds", type=float, default=0.25, help="per timed run")
    ap.add_argument("--quick", action="store_true", help="3 repetitions of 0.05 s")
    args = ap.parse_args(argv)
    reps, seconds = (3, 0.05) if args.quick else (args.reps, args.seconds)
    import numba
    print(f"# benchmarks/fma.py {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"{benchlib.cpu_model()}, numba {numba.__version__}, Python {platform.python_version()}, "
          f"best of {reps} interleaved runs of ~{seconds} s")
    kernels = make_kernels()
    bad = []
    for (kind, shape), form in itertools.product(CASES, FORMS):
        m = measure(kernels, kind, form, shape, reps, seconds)
        report(kind, form, shape, m)
        if not m["diff"] <= TOLERANCE:
            bad.append(f"{kind} {shape} {form}: plain and fma differ by {m['diff']:.1e} of the peak (> {TOLERANCE})")
    for line in bad:
        print("DISAGREE:", line, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
