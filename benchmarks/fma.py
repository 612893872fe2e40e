#!/usr/bin/env python
"""Is fused multiply-add worth it for the one-pass leapfrog of a uniform lattice? (issue 25, item 2)

    python benchmarks/fma.py [--reps 9] [--seconds 0.25] [--quick]

Bare numba (plain @njit: no fast-math, float64), the stencil alone, no hapticgraph:

    x_new[i] = A·x[i] − B·x_old[i] + C·(Σ neighbours of i)

on a 30,000-cell string and on 32 × 32 and 150 × 150 sheets with a fixed boundary (a ghost border
of zeros around the cells), written into the older buffer, the two buffers swapped each step. Two
variants of the same loop:
- plain: `a * x[i] - b * xo[i] + c * s` (numba's LLVM contracts nothing without fast-math);
- fma:   `fma(c, s, fma(a, x[i], -(b * xo[i])))`, fma an explicit `llvm.fma.f64` (numba's extension
  API, `numba.extending.intrinsic`): two of the three products rounded once with their sum.
A, B, C are those of the benchmark lattices (mass 1 g, tension 10⁵ N/m, damping 10⁻⁴, 44.1 kHz).

Each repetition starts both variants from the same random displacement (no subnormal numbers) and
runs the same number of steps (about --seconds each), the two interleaved; steps/s is the best and
the median of --reps. Ratio = fma steps/s / plain steps/s (> 1: FMA is faster). The final states
of the two must agree within rounding: max |plain − fma| ≤ 1e-9 of the peak (they differ only in
where products are rounded; a wrong coefficient or neighbour gives 1e-4 or more). The machine code
is inspected too: the vector width of the loop and the count of packed FMA instructions, so a
figure is never that of a loop that did not vectorise. Exit status 1 if the variants disagree.
"""
import argparse
import datetime
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


def coefficients(dim):
    """(A, B, C) of the damped leapfrog m·(x⁺ − 2x + x⁻)/dt² = T·Δx − R·(x⁺ − x⁻)/(2dt)."""
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
    """{(name, variant): njit function(x, xo, a, b, c, steps) -> (newest, older)}; the fma variants
    are the plain ones with two of their products fused."""
    from numba import njit
    fma = fma_intrinsic()

    @njit
    def string_fma(x, xo, a, b, c, steps):
        n = x.shape[0]
        for _ in range(steps):
            for i in range(1, n - 1):
                xo[i] = fma(c, x[i - 1] + x[i + 1], fma(a, x[i], -(b * xo[i])))
            x, xo = xo, x
        return x, xo

    @njit
    def sheet_fma(x, xo, a, b, c, steps):
        rows, cols = x.shape
        for _ in range(steps):
            for r in range(1, rows - 1):
                for j in range(1, cols - 1):
                    s = (x[r - 1, j] + x[r + 1, j]) + (x[r, j - 1] + x[r, j + 1])
                    xo[r, j] = fma(c, s, fma(a, x[r, j], -(b * xo[r, j])))
            x, xo = xo, x
        return x, xo

    return {("string", "plain"): njit(_string_plain), ("string", "fma"): string_fma,
            ("sheet", "plain"): njit(_sheet_plain), ("sheet", "fma"): sheet_fma}


def _string_plain(x, xo, a, b, c, steps):
    n = x.shape[0]
    for _ in range(steps):
        for i in range(1, n - 1):
            xo[i] = a * x[i] - b * xo[i] + c * (x[i - 1] + x[i + 1])
        x, xo = xo, x
    return x, xo


def _sheet_plain(x, xo, a, b, c, steps):
    rows, cols = x.shape
    for _ in range(steps):
        for r in range(1, rows - 1):
            for j in range(1, cols - 1):
                s = (x[r - 1, j] + x[r + 1, j]) + (x[r, j - 1] + x[r, j + 1])
                xo[r, j] = a * x[r, j] - b * xo[r, j] + c * s
        x, xo = xo, x
    return x, xo


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


def measure(kernels, kind, shape, reps, seconds):
    """One case: steps/s of each variant (best, median), and their disagreement."""
    coef = coefficients(len(shape))
    plain, fused = kernels[(kind, "plain")], kernels[(kind, "fma")]
    for fn in (plain, fused):
        timed(fn, shape, coef, 2)                        # compile and warm
    t, _ = timed(plain, shape, coef, 200)
    steps = max(200, int(seconds / t * 200))
    rates = {"plain": [], "fma": []}
    for _ in range(reps):
        for name, fn in (("plain", plain), ("fma", fused)):
            t, last = timed(fn, shape, coef, steps)
            rates[name].append(steps / t)
            if name == "plain":
                ref = last
            else:
                diff = float(np.max(np.abs(last - ref)) / np.max(np.abs(ref)))
    return {"steps": steps, "rates": rates, "diff": diff,
            "code": {name: machine_code(fn) for name, fn in (("plain", plain), ("fma", fused))}}


def report(kind, shape, m):
    cells = int(np.prod(shape))
    best = {k: max(v) for k, v in m["rates"].items()}
    med = {k: statistics.median(v) for k, v in m["rates"].items()}
    label = f"{kind} {' x '.join(map(str, shape))}"
    (wp, _), (wf, nf) = m["code"]["plain"], m["code"]["fma"]
    print(f"{label:<16} plain {best['plain']:>12,.0f} steps/s ({best['plain'] * cells / 1e9:.2f} G cells/s)"
          f"   fma {best['fma']:>12,.0f} steps/s   ratio fma/plain best {best['fma'] / best['plain']:.3f}"
          f" median {med['fma'] / med['plain']:.3f}   |diff| {m['diff']:.1e} of peak"
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
    for kind, shape in CASES:
        m = measure(kernels, kind, shape, reps, seconds)
        report(kind, shape, m)
        if not m["diff"] <= TOLERANCE:
            bad.append(f"{kind} {shape}: plain and fma differ by {m['diff']:.1e} of the peak (> {TOLERANCE})")
    for line in bad:
        print("DISAGREE:", line, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
