#!/usr/bin/env python
"""Benchmark: hapticgraph's fused mass-spring networks against the same update hand-written in C,
their compile time from 10 to 100,000 cells, and their memory per cell.

    python benchmarks/lattice_vs_c.py [--samples 4410] [--reps 7] [--quick] [--only string,sheet,csr]
                                      [--no-compile] [--no-memory]

1. Throughput, in ONE run, as ratios (C time / hapticgraph time: ≥ 1 means hapticgraph is faster;
   the goal is ≥ 0.8) of
   - a 30,000-cell 1-D lattice (the `string_step` stencil),
   - a 150 × 150 sheet (the `sheet_step` stencil),
   - a joined network on the CSR path (`network_step`): a 150 × 150 sheet with one corner cell
     cut, a 1,000-cell string, and two springs joining the string's ends to the sheet,
   each with a half-sine `pluck` into one cell and one cell's position recorded as the output.
   hapticgraph runs the real path: the patch is written as YAML and loaded, then Program +
   CompiledKernel (compile time excluded), then `CompiledKernel.run` chunk by chunk. The C program
   is written to a temporary folder, compiled with gcc -O3 -march=native -ffp-contract=off (no
   FMA contraction, as numba's LLVM: the same arithmetic) and times itself (clock_gettime,
   CLOCK_MONOTONIC); it is what one would write by hand for the SAME update — the same half-step
   scheme, the same operations in the same order (a stencil with its edges peeled off the
   interior loop; a CSR loop over the very arrays hapticgraph built) — and is verified by its
   output and by a checksum of its final positions and velocities against hapticgraph's.
   Both start from the same random displacement of every cell (so no cell stays at zero and no
   subnormal numbers appear); best of --reps, the two contenders interleaved.
2. Compile time of lattices of 10 … 100,000 cells (1-D stencil, and the same with one cell cut so
   it takes the CSR path), each in a fresh process: cold (new empty HAPTICGRAPH_CACHE and
   NUMBA_CACHE_DIR) and warm (the same folders, a new process). Inside the process the clock
   starts after the imports; numba's one-time initialisation is timed apart; "load+compile" is
   hapticgraph.load (which checks stability, building the network once) + Program +
   CompiledKernel. Goal: numba init + load+compile ≤ 2 s cold, and flat in the number of cells.
3. Memory per cell: the bytes of the fused network's arrays per cell (1-D, 2-D, 2-D with a cut,
   3-D, a joined network), and for 10⁶ cells tracemalloc's retained (after Program) and peak
   (during load + Program) allocations, and the growth of the process's resident set, per cell.
   Goal ≤ 200 B per cell.

Exit status 1 if any C output differs from hapticgraph's by more than 1e-12; the goals are
reported, not enforced. Nothing is written outside temporary folders.
"""
import argparse
import datetime
import json
import os
import pathlib
import platform
import shutil
import subprocess
import sys
import tempfile
import time
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
RATE = 44100
SPEED_GOAL = 0.8          # hapticgraph at least 0.8x the C loop's speed
COLD_GOAL = 2.0           # seconds
BYTES_GOAL = 200          # per cell
TOLERANCE = 1e-12
C_FLAGS = ["-O3", "-march=native", "-ffp-contract=off"]
CHUNK = 1024              # samples per CompiledKernel.run call

# the benchmark's lattices: wave speed √(T/m) = 10⁴ cells/s, dt²·4T/m ≈ 0.2 (stable)
MASS, TENSION, DAMPING = 0.001, 100000.0, 0.0001
PLUCK = {"time": 0.0, "force": 1.0, "duration": 0.001}


def patch_text(kind):
    """YAML of a benchmark network; `exc` gets the pluck, `mic` is the recorded cell."""
    lat = f"mass: {MASS}, tension: {TENSION}, damping: {DAMPING}"
    pick = f"  pick: {{type: pluck, time: {PLUCK['time']}, force: {PLUCK['force']}, duration: {PLUCK['duration']}}}\n"
    head = f"hapticgraph: 1\nname: lattice benchmark ({kind})\nrate: {RATE}\nblocks:\n"
    out = "  out: {type: audio_out, channels: 1}\n"
    if kind == "string":
        return (head + f"  s: {{type: lattice, shape: [30000], {lat}}}\n" + pick + out +
                "connect:\n  - pick.out -> s[15000].force\n  - s[15300].position -> out.ch0\n")
    if kind == "sheet":
        return (head + f"  s: {{type: lattice, shape: [150, 150], {lat}}}\n" + pick + out +
                "connect:\n  - pick.out -> s[75, 75].force\n  - s[80, 80].position -> out.ch0\n")
    if kind == "csr":
        return (head + f"  s: {{type: lattice, shape: [150, 150], {lat}, cut: [[0, 0]]}}\n"
                f"  w: {{type: lattice, shape: [1000], {lat}}}\n"
                "  j1: {type: spring, a: \"s[75, 10]\", b: \"w[0]\", tension: 50000.0}\n"
                "  j2: {type: spring, a: \"s[75, 140]\", b: \"w[999]\", tension: 50000.0}\n" + pick + out +
                "connect:\n  - pick.out -> s[75, 75].force\n  - w[500].position -> out.ch0\n")
    raise ValueError(kind)


# ---------------------------------------------------------------------------------------------
# the C program
# ---------------------------------------------------------------------------------------------
C_SOURCE = r"""
/* Hand-written half-step mass-spring updates: the same arithmetic as blocks/massspring's
   string_step, sheet_step and network_step, and the pluck and the recorded cell of the
   benchmark's patches. Usage: lattice MODE DIR SAMPLES REPS (MODE: string | sheet | csr). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    double n, dt, mass, tension, damping, fixed, exc, mic, at, width, force, rows, cols, ncomp;
} Params;

static void *slurp(const char *dir, const char *name, size_t *bytes)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *fp = fopen(path, "rb");
    if (!fp) { fprintf(stderr, "cannot open %s\n", path); exit(1); }
    fseek(fp, 0, SEEK_END);
    long size = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    void *data = malloc(size > 0 ? size : 1);
    if (!data || fread(data, 1, size, fp) != (size_t)size) { fprintf(stderr, "cannot read %s\n", path); exit(1); }
    fclose(fp);
    if (bytes) *bytes = size;
    return data;
}

static void dump(const char *dir, const char *name, const double *x, int64_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *fp = fopen(path, "wb");
    if (!fp || fwrite(x, sizeof(double), n, fp) != (size_t)n) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fclose(fp);
}

static inline double pluck(int64_t t, double at, double width, double force)
{
    const double k = (double)t - at;
    if (k < 0.0 || k >= width)
        return 0.0;
    return force * sin(M_PI * (k + 0.5) / width);
}

__attribute__((noinline))
static void run_string(int64_t ns, const Params *p, double *restrict pos, double *restrict vel,
                       double *restrict frc, double *restrict out)
{
    const int64_t n = (int64_t)p->n, exc = (int64_t)p->exc, mic = (int64_t)p->mic;
    const double dt = p->dt, tension = p->tension, damping = p->damping;
    const double w = dt * (1.0 / p->mass);
    const double end = p->fixed != 0.0 ? tension : 0.0;
    for (int64_t t = 0; t < ns; t++) {
        const double f = pluck(t, p->at, p->width, p->force);
        out[t] = pos[mic];
        frc[exc] += f;
        vel[0] += w * (tension * (pos[1] - pos[0]) - end * pos[0] + frc[0] - damping * vel[0]);
        frc[0] = 0.0;
        for (int64_t i = 1; i < n - 1; i++) {
            vel[i] += w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) + frc[i] - damping * vel[i]);
            frc[i] = 0.0;
        }
        vel[n - 1] += w * (tension * (pos[n - 2] - pos[n - 1]) - end * pos[n - 1] + frc[n - 1] - damping * vel[n - 1]);
        frc[n - 1] = 0.0;
        for (int64_t i = 0; i < n; i++)
            pos[i] += dt * vel[i];
    }
}

/* one cell of the sheet with every boundary test (the edges) */
static inline void sheet_cell(int64_t r, int64_t c, int64_t rows, int64_t cols, int fixed, double w,
                              double tension, double damping, const double *pos, double *vel, double *frc)
{
    const int64_t i = r * cols + c;
    const double xi = pos[i];
    double f = 0.0;
    if (r > 0) f += pos[i - cols] - xi; else if (fixed) f -= xi;
    if (r < rows - 1) f += pos[i + cols] - xi; else if (fixed) f -= xi;
    if (c > 0) f += pos[i - 1] - xi; else if (fixed) f -= xi;
    if (c < cols - 1) f += pos[i + 1] - xi; else if (fixed) f -= xi;
    vel[i] += w * (tension * f + frc[i] - damping * vel[i]);
    frc[i] = 0.0;
}

__attribute__((noinline))
static void run_sheet(int64_t ns, const Params *p, double *restrict pos, double *restrict vel,
                      double *restrict frc, double *restrict out)
{
    const int64_t rows = (int64_t)p->rows, cols = (int64_t)p->cols, exc = (int64_t)p->exc, mic = (int64_t)p->mic;
    const int fixed = p->fixed != 0.0;
    const double dt = p->dt, tension = p->tension, damping = p->damping;
    const double w = dt * (1.0 / p->mass);
    for (int64_t t = 0; t < ns; t++) {
        const double f = pluck(t, p->at, p->width, p->force);
        out[t] = pos[mic];
        frc[exc] += f;
        for (int64_t c = 0; c < cols; c++)
            sheet_cell(0, c, rows, cols, fixed, w, tension, damping, pos, vel, frc);
        for (int64_t r = 1; r < rows - 1; r++) {
            sheet_cell(r, 0, rows, cols, fixed, w, tension, damping, pos, vel, frc);
            const double *up = pos + (r - 1) * cols, *mid = pos + r * cols, *down = pos + (r + 1) * cols;
            double *v = vel + r * cols, *fr = frc + r * cols;
            for (int64_t c = 1; c < cols - 1; c++) {     /* the interior: no tests */
                const double xi = mid[c];
                const double s = (((up[c] - xi) + (down[c] - xi)) + (mid[c - 1] - xi)) + (mid[c + 1] - xi);
                v[c] += w * (tension * s + fr[c] - damping * v[c]);
                fr[c] = 0.0;
            }
            sheet_cell(r, cols - 1, rows, cols, fixed, w, tension, damping, pos, vel, frc);
        }
        for (int64_t c = 0; c < cols; c++)
            sheet_cell(rows - 1, c, rows, cols, fixed, w, tension, damping, pos, vel, frc);
        for (int64_t i = 0; i < rows * cols; i++)
            pos[i] += dt * vel[i];
    }
}

typedef struct {
    const uint32_t *cid, *rowptr, *col, *jrow, *jcol;
    const double *inv_m, *damp, *anchor, *kr, *jk, *scale;
} Csr;

__attribute__((noinline))
static void run_csr(int64_t ns, const Params *p, const Csr *g, double *restrict pos, double *restrict vel,
                    double *restrict frc, double *restrict out)
{
    const int64_t n = (int64_t)p->n, exc = (int64_t)p->exc, mic = (int64_t)p->mic;
    const double dt = p->dt;
    for (int64_t t = 0; t < ns; t++) {
        const double fp = pluck(t, p->at, p->width, p->force);
        out[t] = pos[mic];
        frc[exc] += fp;
        for (int64_t i = 0; i < n; i++) {
            const uint32_t c = g->cid[i];
            const double xi = pos[i];
            double f = 0.0;
            for (uint32_t e = g->rowptr[i]; e < g->rowptr[i + 1]; e++)
                f += g->kr[e] * (pos[g->col[e]] - xi);
            f = g->scale[3 * c + 1] * (f - g->anchor[i] * xi);
            for (uint32_t e = g->jrow[i]; e < g->jrow[i + 1]; e++)
                f += g->jk[e] * (pos[g->jcol[e]] - xi);
            const double wi = g->inv_m[i] * g->scale[3 * c];
            vel[i] += dt * wi * (f + frc[i] - (g->scale[3 * c + 2] + g->damp[i]) * vel[i]);
            frc[i] = 0.0;
        }
        for (int64_t i = 0; i < n; i++)
            pos[i] += dt * vel[i];
    }
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc != 5) { fprintf(stderr, "usage: %s string|sheet|csr DIR SAMPLES REPS\n", argv[0]); return 2; }
    const char *mode = argv[1], *dir = argv[2];
    const int64_t ns = atoll(argv[3]);
    const int reps = atoi(argv[4]);
    Params p;
    double *raw = slurp(dir, "params.f64", NULL);
    memcpy(&p, raw, sizeof p);
    const int64_t n = (int64_t)p.n;
    double *pos0 = slurp(dir, "pos0.f64", NULL);
    double *pos = malloc(n * sizeof(double)), *vel = malloc(n * sizeof(double));
    double *frc = malloc(n * sizeof(double)), *out = malloc(ns * sizeof(double));
    Csr g = {0};
    if (!strcmp(mode, "csr")) {
        g.cid = slurp(dir, "cid.u32", NULL); g.rowptr = slurp(dir, "rowptr.u32", NULL);
        g.col = slurp(dir, "col.u32", NULL); g.jrow = slurp(dir, "jrow.u32", NULL);
        g.jcol = slurp(dir, "jcol.u32", NULL); g.inv_m = slurp(dir, "inv_m.f64", NULL);
        g.damp = slurp(dir, "damp.f64", NULL); g.anchor = slurp(dir, "anchor.f64", NULL);
        g.kr = slurp(dir, "kr.f64", NULL); g.jk = slurp(dir, "jk.f64", NULL);
        double *scale = slurp(dir, "scale.f64", NULL);   /* per component: 1/mass, tension, damping */
        g.scale = scale;
    }
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        memcpy(pos, pos0, n * sizeof(double));
        memset(vel, 0, n * sizeof(double));
        memset(frc, 0, n * sizeof(double));
        memset(out, 0, ns * sizeof(double));
        const double start = now();
        if (!strcmp(mode, "string")) run_string(ns, &p, pos, vel, frc, out);
        else if (!strcmp(mode, "sheet")) run_sheet(ns, &p, pos, vel, frc, out);
        else if (!strcmp(mode, "csr")) run_csr(ns, &p, &g, pos, vel, frc, out);
        else { fprintf(stderr, "unknown mode %s\n", mode); return 2; }
        const double elapsed = now() - start;
        if (elapsed < best) best = elapsed;
    }
    double sum = 0.0;
    for (int64_t i = 0; i < n; i++) sum += pos[i] + vel[i];
    dump(dir, "out.f64", out, ns);
    dump(dir, "pos.f64", pos, n);
    dump(dir, "vel.f64", vel, n);
    printf("best_seconds %.9f\nchecksum %.17g\n", best, sum);
    return 0;
}
"""


def build_c(tmp):
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        return None, "no C compiler found"
    src, exe = tmp / "lattice.c", tmp / "lattice"
    src.write_text(C_SOURCE)
    proc = subprocess.run([cc, *C_FLAGS, str(src), "-o", str(exe), "-lm"], capture_output=True, text=True)
    if proc.returncode != 0:
        return None, f"C build failed: {proc.stderr.strip()[:400]}"
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return exe, version


def run_c(exe, mode, folder, samples, reps):
    import numpy as np
    proc = subprocess.run([str(exe), mode, str(folder), str(samples), str(reps)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"C run failed ({proc.returncode}): {proc.stderr.strip()[:300]}")
    result = dict(line.split() for line in proc.stdout.splitlines())
    return (float(result["best_seconds"]), float(result["checksum"]),
            {k: np.fromfile(folder / f"{k}.f64") for k in ("out", "pos", "vel")})


# ---------------------------------------------------------------------------------------------
# throughput
# ---------------------------------------------------------------------------------------------
def setup(kind, folder):
    """Load the patch, plan it, compile it (excluded from the timings) and return a factory of
    fresh runs: each makes a new Program (state at rest, then the shared random displacement)."""
    import numpy as np

    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program

    path = folder / f"{kind}.yaml"
    path.write_text(patch_text(kind), encoding="utf-8")
    patch = load(str(path))
    start = time.perf_counter()
    CompiledKernel(Program(patch, drivers={}))
    compile_seconds = time.perf_counter() - start
    net0 = Program(patch, drivers={}).groups[0].group
    pos0 = np.random.default_rng(20261121).uniform(-1e-3, 1e-3, net0.n)

    def fresh():
        prog = Program(patch, drivers={})
        ck = CompiledKernel(prog)                          # compiled already: fresh state only
        plan = prog.groups[0]
        plan.group.pos[:] = pos0
        return prog, ck, plan

    prog, _, plan = fresh()
    net = plan.group
    comp = {c.name: c for c in net.components}
    exc_flat = next(iter(plan.forces))
    mic_flat = prog.records[0][1].terms[0].index           # the recorded cell: Total of one ArrayItem
    width = max(1, int(round(PLUCK["duration"] * RATE)))
    first = net.components[0]
    rows, cols = (first.shape + (1,))[:2] if len(first.shape) >= 1 else (1, 1)
    params = [net.n, net.dt, MASS, TENSION, DAMPING, 1.0, exc_flat, mic_flat, float(round(PLUCK["time"] * RATE)),
              float(width), PLUCK["force"], float(rows), float(cols), float(len(net.components))]
    np.asarray(params, dtype=np.float64).tofile(folder / "params.f64")
    pos0.tofile(folder / "pos0.f64")
    if net.stencil is None:
        for name in ("cid", "rowptr", "col", "jrow", "jcol"):
            a = getattr(net, name)
            assert a.dtype == np.uint32, (name, a.dtype)
            a.tofile(folder / f"{name}.u32")
        for name in ("inv_m", "damp", "anchor", "kr", "jk"):
            getattr(net, name).astype(np.float64).tofile(folder / f"{name}.f64")
        scale = np.array([[1.0 / c.inst.values["mass"], c.inst.values["tension"], c.inst.values["damping"]]
                          for c in net.components])
        scale.tofile(folder / "scale.f64")
    return {"fresh": fresh, "n": net.n, "path": net.stencil or "csr", "compile": compile_seconds,
            "components": list(comp)}


def time_hapticgraph(fresh, samples):
    import numpy as np
    prog, ck, plan = fresh()
    rec = np.zeros((samples, len(prog.records)))
    ext = np.zeros((samples, len(prog.ext_columns)))
    rec.fill(0.0)
    start = time.perf_counter()
    for a in range(0, samples, CHUNK):
        b = min(samples, a + CHUNK)
        ck.run(a, rec[a:b], ext[a:b])
    elapsed = time.perf_counter() - start
    return elapsed, {"out": rec[:, 0].copy(), "pos": plan.group.pos.copy(), "vel": plan.group.vel.copy()}


def throughput(kinds, samples, reps, exe):
    import numpy as np
    rows = []
    for kind in kinds:
        with tempfile.TemporaryDirectory(prefix=f"hg-lattice-{kind}-") as tmp:
            folder = pathlib.Path(tmp)
            s = setup(kind, folder)
            best_hg, best_c = float("inf"), float("inf")
            hg_out = c_out = None
            checksum = None
            for _ in range(reps):                  # interleaved: load on the machine hits both alike
                t, hg_out = time_hapticgraph(s["fresh"], samples)
                best_hg = min(best_hg, t)
                if exe is not None:
                    t, checksum, c_out = run_c(exe, kind, folder, samples, 1)
                    best_c = min(best_c, t)
            diff = sum_diff = None
            if c_out is not None:
                # every output sample and the final state of every cell, and the C program's own
                # checksum (Σ pos + vel, summed in C's order) against the same sum of ours
                diff = max(float(np.max(np.abs(hg_out[k] - c_out[k]))) for k in ("out", "pos", "vel"))
                sum_diff = abs(float(np.cumsum(hg_out["pos"] + hg_out["vel"])[-1]) - checksum)
            cells = s["n"]
            rows.append({"kind": kind, "path": s["path"], "cells": cells, "samples": samples,
                         "hg_seconds": best_hg, "c_seconds": best_c if exe is not None else None,
                         "hg_ns_per_cell": best_hg / samples / cells * 1e9,
                         "c_ns_per_cell": best_c / samples / cells * 1e9 if exe is not None else None,
                         "ratio": best_c / best_hg if exe is not None else None, "diff": diff,
                         "checksum": checksum, "checksum_diff": sum_diff,
                         "peak": float(np.max(np.abs(hg_out["out"])))})
    return rows


# ---------------------------------------------------------------------------------------------
# compile time
# ---------------------------------------------------------------------------------------------
def sized_patch(cells, cut):
    extra = ", cut: [[1]]" if cut else ""
    return (f"hapticgraph: 1\nname: lattice of {cells}\nrate: {RATE}\nblocks:\n"
            f"  s: {{type: lattice, shape: [{cells}], {'mass: ' + str(MASS)}, tension: {TENSION}{extra}}}\n"
            f"  pick: {{type: pluck, time: 0.0, force: 1.0, duration: 0.001}}\n"
            f"  out: {{type: audio_out, channels: 1}}\n"
            f"connect:\n  - pick.out -> s[{cells // 2}].force\n  - s[{cells - 1}].position -> out.ch0\n")


def compile_child(patch_path):
    """In a fresh process: import, numba's initialisation, then load + Program + CompiledKernel."""
    t0 = time.perf_counter()
    import numba  # noqa: F401
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program
    t1 = time.perf_counter()
    result = {"import": t1 - t0, "numba_init": 0.0}
    try:
        from numba.core.registry import cpu_target
        cpu_target.target_context.refresh()
        cpu_target.typing_context.refresh()
        t2 = time.perf_counter()
        result["numba_init"] = t2 - t1
        t1 = t2
    except Exception:  # noqa: BLE001 - an internal API; without it the init counts as compile
        pass
    patch = load(patch_path)
    t2 = time.perf_counter()
    prog = Program(patch, drivers={})
    t3 = time.perf_counter()
    ck = CompiledKernel(prog)
    t4 = time.perf_counter()
    result.update(load=t2 - t1, program=t3 - t2, kernel=t4 - t3, load_compile=t4 - t1)
    print("RESULT " + json.dumps(result))


def run_child(path, env):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, str(pathlib.Path(__file__).resolve()), "--compile-child", str(path)],
                          env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            r = json.loads(line[7:])
            r["process"] = wall
            return r
    raise RuntimeError(f"compile child failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}")


def compile_times(sizes, cold_runs, warm_runs):
    rows = []
    with tempfile.TemporaryDirectory(prefix="hg-lattice-compile-") as tmp:
        tmp = pathlib.Path(tmp)
        for cut in (False, True):
            for cells in sizes:
                path = tmp / f"s{cells}{'_cut' if cut else ''}.yaml"
                path.write_text(sized_patch(cells, cut), encoding="utf-8")
                colds, warms = [], []
                for k in range(cold_runs):
                    hg, nb = tmp / f"hg{cells}{cut}{k}", tmp / f"nb{cells}{cut}{k}"
                    env = dict(os.environ, HAPTICGRAPH_CACHE=str(hg), NUMBA_CACHE_DIR=str(nb))
                    env.pop("HAPTICGRAPH_DUMP", None)
                    colds.append(run_child(path, env))
                    if k == cold_runs - 1:
                        warms = [run_child(path, env) for _ in range(warm_runs)]
                total = lambda r: r["numba_init"] + r["load_compile"]      # noqa: E731
                rows.append({"cells": cells, "path": "csr" if cut else "string",
                             "cold": min(colds, key=total), "warm": min(warms, key=total)})
    return rows


# ---------------------------------------------------------------------------------------------
# memory
# ---------------------------------------------------------------------------------------------
NETWORK_ARRAYS = ("pos", "vel", "frc", "inv_m", "damp", "anchor", "cid", "rowptr", "col", "kr", "jrow", "jcol", "jk")


def network_bytes(prog):
    """Bytes held per network: the kernel's arrays, the scale table and each lattice's index maps."""
    total = 0
    for plan in prog.groups:
        net = plan.group
        total += sum(getattr(net, k).nbytes for k in NETWORK_ARRAYS) + plan.scale.nbytes
        total += sum(c.compact.nbytes + c.alive.nbytes for c in net.components)
    return total


def memory_patch(kind, big):
    lat = f"mass: {MASS}, tension: 1000.0"
    shapes = {"1-D": ("[1000000]" if big else "[30000]", ""),
              "2-D": ("[1000, 1000]" if big else "[150, 150]", ""),
              "2-D cut (CSR)": ("[1000, 1000]" if big else "[150, 150]", ", cut: [[0, 0]]"),
              "3-D (CSR)": ("[100, 100, 100]" if big else "[30, 30, 30]", "")}
    if kind == "joined (CSR)":
        body = (f"  s: {{type: lattice, shape: {'[990, 1000]' if big else '[150, 150]'}, {lat}}}\n"
                f"  w: {{type: lattice, shape: [10000], {lat}}}\n"
                "  j: {type: spring, a: \"s[0, 0]\", b: \"w[0]\", tension: 100.0}\n")
    else:
        shape, extra = shapes[kind]
        body = f"  s: {{type: lattice, shape: {shape}, {lat}{extra}}}\n"
    return f"hapticgraph: 1\nrate: {RATE}\nblocks:\n{body}"


def rss():
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def memory_child(kind):
    """In a fresh process: tracemalloc retained/peak and RSS growth of load + Program, 10⁶ cells."""
    import tracemalloc
    import numpy as np  # noqa: F401
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "m.yaml"
        path.write_text(memory_patch(kind, big=True), encoding="utf-8")
        before = rss()
        tracemalloc.start()
        prog = Program(load(str(path)), drivers={})
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        after = rss()
        n = sum(p.group.n for p in prog.groups)
        print("RESULT " + json.dumps({"cells": n, "arrays": network_bytes(prog) / n, "retained": current / n,
                                      "peak": peak / n,
                                      "rss": (after - before) / n if before and after else None}))


def memory():
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program
    rows = []
    with tempfile.TemporaryDirectory(prefix="hg-lattice-mem-") as tmp:
        for kind in ("1-D", "2-D", "2-D cut (CSR)", "3-D (CSR)", "joined (CSR)"):
            path = pathlib.Path(tmp) / "m.yaml"
            path.write_text(memory_patch(kind, big=False), encoding="utf-8")
            prog = Program(load(str(path)), drivers={})
            n = sum(p.group.n for p in prog.groups)
            proc = subprocess.run([sys.executable, str(pathlib.Path(__file__).resolve()), "--memory-child", kind],
                                  capture_output=True, text=True)
            big = next((json.loads(ln[7:]) for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")),
                       {"error": (proc.stderr.strip().splitlines() or ["?"])[-1]})
            rows.append({"kind": kind, "cells": n, "arrays": network_bytes(prog) / n,
                         "path": prog.groups[0].group.stencil or "csr", "big": big})
    return rows


# ---------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------
def machine():
    cpu = benchlib.cpu_model()
    import numba
    import numpy
    return (f"{cpu}, {os.cpu_count()} CPUs, Python {platform.python_version()}, numba {numba.__version__}, "
            f"numpy {numpy.__version__}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4410, help="samples per timed run (default 0.1 s)")
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--only", default="string,sheet,csr")
    ap.add_argument("--quick", action="store_true", help="fewer samples, reps and compile runs")
    ap.add_argument("--no-compile", action="store_true")
    ap.add_argument("--no-memory", action="store_true")
    ap.add_argument("--json", help="also write the results to this file")
    ap.add_argument("--compile-child", help=argparse.SUPPRESS)
    ap.add_argument("--memory-child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.compile_child:
        compile_child(args.compile_child)
        return 0
    if args.memory_child:
        memory_child(args.memory_child)
        return 0
    if args.quick:
        args.samples, args.reps = min(args.samples, 1024), min(args.reps, 3)
    with tempfile.TemporaryDirectory(prefix="hg-lattice-kernels-") as kernels:
        os.environ.setdefault("HAPTICGRAPH_CACHE", kernels)    # the user's cache stays untouched
        return measure(args)


def measure(args):
    print(f"# lattice benchmark, {datetime.date.today()}: {machine()}")
    status = 0
    results = {}
    with tempfile.TemporaryDirectory(prefix="hg-lattice-c-") as tmp:
        exe, version = build_c(pathlib.Path(tmp))
        print(f"# C: {version if exe else 'skipped: ' + version} {' '.join(C_FLAGS) if exe else ''}")
        rows = throughput(args.only.split(","), args.samples, args.reps, exe)
    results["throughput"] = rows
    print(f"\n## Throughput: {args.samples} samples per run, best of {args.reps}, ns per cell and sample")
    print(f"{'network':8} {'path':7} {'cells':>7} {'hapticgraph':>12} {'C':>8} {'C time/hg time':>15}  goal   "
          f"max|diff| checksum diff")
    for r in rows:
        met = "" if r["ratio"] is None else ("met" if r["ratio"] >= SPEED_GOAL else "NOT met")
        c = "-" if r["c_ns_per_cell"] is None else f"{r['c_ns_per_cell']:.3f}"
        ratio = "-" if r["ratio"] is None else f"{r['ratio']:.2f}x"
        diff = "-" if r["diff"] is None else f"{r['diff']:.1e}"
        sums = "-" if r["checksum_diff"] is None else f"{r['checksum_diff']:.1e}"
        print(f"{r['kind']:8} {r['path']:7} {r['cells']:7d} {r['hg_ns_per_cell']:12.3f} {c:>8} {ratio:>15}  "
              f"{met:7} {diff:9} {sums}")
        if r["diff"] is not None and max(r["diff"], r["checksum_diff"]) > TOLERANCE:
            status = 1
    if not args.no_compile:
        sizes = [10, 1000, 100000] if args.quick else [10, 100, 1000, 10000, 100000]
        rows = compile_times(sizes, cold_runs=1 if args.quick else 2, warm_runs=1 if args.quick else 3)
        results["compile"] = rows
        print("\n## Compile time (s): numba init + load+compile (load | Program | CompiledKernel), fresh process")
        print(f"{'cells':>7} {'path':7} {'cold total':>10} {'(init':>6} {'load':>6} {'Program':>8} {'kernel)':>8} "
              f"{'warm total':>10} {'process cold/warm':>18}")
        for r in rows:
            c, w = r["cold"], r["warm"]
            print(f"{r['cells']:7d} {r['path']:7} {c['numba_init'] + c['load_compile']:10.2f} {c['numba_init']:6.2f} "
                  f"{c['load']:6.3f} {c['program']:8.3f} {c['kernel']:8.2f} "
                  f"{w['numba_init'] + w['load_compile']:10.2f} {c['process']:8.2f} / {w['process']:.2f}")
    if not args.no_memory:
        rows = memory()
        results["memory"] = rows
        print("\n## Memory (bytes per cell): network arrays; for 10⁶ cells: arrays, tracemalloc retained / peak, RSS growth")
        for r in rows:
            b = r["big"]
            big = (f"{b['arrays']:.0f} | {b['retained']:.0f} / {b['peak']:.0f} | "
                   f"{b['rss']:.0f}" if "error" not in b else b["error"])
            print(f"{r['kind']:14} {r['path']:6} {r['cells']:7d} cells: {r['arrays']:6.1f}   "
                  f"{b.get('cells', 0):8d} cells: {big}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=1, default=float))
    return status


if __name__ == "__main__":
    sys.exit(main())
