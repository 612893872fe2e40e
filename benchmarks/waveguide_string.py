#!/usr/bin/env python
"""Benchmark: the block-built kernel of a bidirectional waveguide string against the same model
written by hand in numba and in C, and the compile times of every patch.

    python benchmarks/waveguide_string.py [--seconds 20] [--reps 15] [--quick]

1. Throughput (samples per second, best of --reps, compile time excluded) of
   - the kernel hapticgraph generates for benchmarks/waveguide_string.yaml (CompiledKernel.run
     over the whole render in one call, into a prefaulted buffer),
   - the same model as a hand-written numba loop (hand_string.string_hand) and as a hand-written
     loop that repeats the generated kernel's arithmetic operation for operation
     (hand_string.string_mirror), measured the same way,
   - the same model as a hand-written C loop (gcc -O3 -march=native -ffp-contract=off, timed
     inside the C program with clock_gettime),
   - hapticgraph.graph.engine.render() end to end (its run_seconds: the kernel called chunk by
     chunk into a freshly allocated recording) against the hand numba loop run the same way.
   Every output is checked against the block-built kernel's (max |difference| <= 1e-12).
2. Compile time of every patch in patches/ and of the benchmark's patch, each in a fresh
   process: cold (new empty HAPTICGRAPH_CACHE and NUMBA_CACHE_DIR) and warm (the same folders,
   a second process). "load+compile" is hapticgraph.load + Program + CompiledKernel inside the
   process, after the imports; "process" is the whole process's wall time, Python start-up and
   imports included.

Nothing is written outside temporary folders, except numba's cache of hand_string.py (beside it,
in __pycache__, unless NUMBA_CACHE_DIR says otherwise).
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
REPO = HERE.parent
PATCH = HERE / "waveguide_string.yaml"
RATE_GOAL = 1.25          # block-built kernel within 1.25x of the hand-written numba loop
COLD_GOAL, WARM_GOAL = 2.0, 0.5   # seconds, load+compile, any patch in patches/
TOLERANCE = 1e-12


# ---------------------------------------------------------------------------------------------
# the engine's API, as it is at the time (device drivers and the `ext` input array came later)
# ---------------------------------------------------------------------------------------------
def _accepts(fn, name):
    import inspect
    return name in inspect.signature(fn).parameters


def open_drivers(patch):
    """The patch's device drivers (simulated by default), or None where this version has none."""
    try:
        from hapticgraph.devices import open_drivers as _open
    except ImportError:
        return None
    return _open(patch)


def make_program(patch, drivers=None):
    from hapticgraph.graph.program import Program
    if _accepts(Program, "drivers"):
        return Program(patch, drivers=open_drivers(patch) if drivers is None else drivers)
    return Program(patch)


def run_kernel(ck, t0, rec, ext=None):
    """CompiledKernel.run over rec's rows (with an `ext` array of device inputs where it takes one)."""
    if _accepts(ck.run, "ext"):
        import numpy as np
        if ext is None:
            ext = np.zeros((rec.shape[0], len(getattr(ck.prog, "ext_columns", ()))))
        return ck.run(t0, rec, ext)
    return ck.run(t0, rec)


def engine_render(patch, seconds):
    from hapticgraph.graph.engine import render
    if _accepts(render, "drivers"):
        return render(patch, seconds, progress=False, drivers=open_drivers(patch))
    return render(patch, seconds, progress=False)


def engine_chunk():
    import inspect

    from hapticgraph.graph.engine import render
    return inspect.signature(render).parameters["chunk"].default


# ---------------------------------------------------------------------------------------------
# compile-time child process
# ---------------------------------------------------------------------------------------------
def compile_child(patch_path):
    """Runs in a fresh process: import, then time load + Program + CompiledKernel; print JSON."""
    t0 = time.perf_counter()
    import numba  # noqa: F401
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load
    from hapticgraph.graph.program import Program  # noqa: F401
    t1 = time.perf_counter()
    result = {"import": t1 - t0, "numba_init": 0.0}
    try:
        # numba initialises its compiler (typing and lowering registries, a BLAS probe that
        # imports scipy.linalg) on first use in a process, whatever is compiled or loaded from
        # its cache: timed apart, so "load+compile" is what hapticgraph itself costs
        from numba.core.registry import cpu_target
        cpu_target.target_context.refresh()
        cpu_target.typing_context.refresh()
        t1b = time.perf_counter()
        result["numba_init"] = t1b - t1
        t1 = t1b
    except Exception:  # noqa: BLE001 - an internal API: without it, the init counts as compile
        t1 = time.perf_counter()
    try:
        patch = load(patch_path)
        t2 = time.perf_counter()
        prog = make_program(patch)
        ck = CompiledKernel(prog)
        t3 = time.perf_counter()
        result.update(load=t2 - t1, load_compile=t3 - t1, kernel=ck.compile_seconds)
    except Exception as exc:  # noqa: BLE001 - reported by the parent
        result["error"] = f"{type(exc).__name__}: {exc}".splitlines()[0][:200]
    print("RESULT " + json.dumps(result))


def run_child(patch_path, env):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, str(pathlib.Path(__file__).resolve()), "--compile-child",
                           str(patch_path)], env=env, capture_output=True, text=True, cwd=str(REPO))
    wall = time.perf_counter() - start
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            result = json.loads(line[7:])
            result["process"] = wall
            return result
    tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
    return {"error": f"child failed ({proc.returncode}): {tail[:200]}", "process": wall}


def _best(results):
    ok = [r for r in results if "error" not in r]
    return min(ok, key=lambda r: r["load_compile"] + r["numba_init"]) if ok else results[0]


def compile_times(patch_path, cold_runs=2, warm_runs=3):
    """(best cold, best warm) of fresh processes. Each cold run gets new, empty HAPTICGRAPH_CACHE
    and NUMBA_CACHE_DIR folders; the warm runs reuse the last cold run's folders."""
    colds, warms = [], []
    for k in range(cold_runs):
        with tempfile.TemporaryDirectory(prefix="hg-cache-") as hg, \
                tempfile.TemporaryDirectory(prefix="numba-cache-") as nb:
            env = dict(os.environ, HAPTICGRAPH_CACHE=hg, NUMBA_CACHE_DIR=nb)
            env.pop("HAPTICGRAPH_DUMP", None)
            colds.append(run_child(patch_path, env))
            if k == cold_runs - 1:
                warms = [run_child(patch_path, env) for _ in range(warm_runs)]
    return _best(colds), _best(warms)


# ---------------------------------------------------------------------------------------------
# the C loop
# ---------------------------------------------------------------------------------------------
C_SOURCE = r"""
/* The waveguide string of benchmarks/waveguide_string.yaml, by hand (see hand_string.py). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MASK 127
#define HMASK 3
#define D1 88
#define D2 112
#define WIDTH 44

static double r1[MASK + 1], r2[MASK + 1], l2[MASK + 1], l1[MASK + 1], h[HMASK + 1];

__attribute__((noinline))
static void string_c(int64_t n, int64_t t0, double *restrict out, double force, double g_bridge,
                     double g_nut, double g_mic, double pan)
{
    const double c_left = cos((pan + 1.0) * (0.25 * M_PI));
    for (int64_t i = 0; i < n; i++) {
        const int64_t t = t0 + i;
        const double k = (double)t - 0.0;
        double f = 0.0;
        if (k >= 0.0 && k < WIDTH)
            f = force * sin(M_PI * (k + 0.5) / WIDTH);
        const double a1 = r1[(t - D1) & MASK];
        const double a2 = r2[(t - D2) & MASK];
        const double lp = g_bridge * (0.25 * a2 + 0.5 * h[(t - 1) & HMASK] + 0.25 * h[(t - 2) & HMASK]);
        const double b2 = l2[(t - D2) & MASK];
        const double b1 = l1[(t - D1) & MASK];
        out[i] = (g_mic * (a1 + b2)) * c_left;
        r1[t & MASK] = g_nut * b1;
        r2[t & MASK] = a1 + f;
        h[t & HMASK] = a2;
        l2[t & MASK] = lp;
        l1[t & MASK] = b2 + f;
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
    if (argc != 9) {
        fprintf(stderr, "usage: %s N REPS OUT.f64 FORCE G_BRIDGE G_NUT G_MIC PAN\n", argv[0]);
        return 2;
    }
    const int64_t n = atoll(argv[1]);
    const int reps = atoi(argv[2]);
    const double force = atof(argv[4]), g_bridge = atof(argv[5]), g_nut = atof(argv[6]);
    const double g_mic = atof(argv[7]), pan = atof(argv[8]);
    double *out = malloc(n * sizeof(double));
    if (!out)
        return 1;
    memset(out, 0, n * sizeof(double));   /* fault the pages in before timing */
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        memset(r1, 0, sizeof r1); memset(r2, 0, sizeof r2); memset(l2, 0, sizeof l2);
        memset(l1, 0, sizeof l1); memset(h, 0, sizeof h);
        const double start = now();
        string_c(n, 0, out, force, g_bridge, g_nut, g_mic, pan);
        const double elapsed = now() - start;
        if (elapsed < best)
            best = elapsed;
    }
    double sum = 0.0, sum_abs = 0.0;
    for (int64_t i = 0; i < n; i++) {
        sum += out[i];
        sum_abs += fabs(out[i]);
    }
    FILE *fp = fopen(argv[3], "wb");
    if (!fp || fwrite(out, sizeof(double), n, fp) != (size_t)n)
        return 1;
    fclose(fp);
    printf("samples_per_second %.6e\nbest_seconds %.9f\nchecksum %.17g\nchecksum_abs %.17g\n",
           n / best, best, sum, sum_abs);
    free(out);
    return 0;
}
"""

C_FLAGS = ["-O3", "-march=native", "-ffp-contract=off"]


def run_c(n, reps, gains):
    """Compile and run the C loop; returns (result dict, output array) or (None, reason)."""
    import numpy as np
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        return None, "no C compiler found"
    with tempfile.TemporaryDirectory(prefix="hg-bench-c-") as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "string.c").write_text(C_SOURCE)
        exe, dump = tmp / "string", tmp / "out.f64"
        build = subprocess.run([cc, *C_FLAGS, str(tmp / "string.c"), "-o", str(exe), "-lm"],
                               capture_output=True, text=True)
        if build.returncode != 0:
            return None, f"C build failed: {build.stderr.strip()[:300]}"
        proc = subprocess.run([str(exe), str(n), str(reps), str(dump), *[repr(g) for g in gains]],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            return None, f"C run failed ({proc.returncode}): {proc.stderr.strip()[:300]}"
        result = {}
        for line in proc.stdout.splitlines():
            key, value = line.split()
            result[key] = float(value)
        result["compiler"] = subprocess.run([cc, "--version"], capture_output=True,
                                            text=True).stdout.splitlines()[0]
        return result, np.fromfile(dump, dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# throughput
# ---------------------------------------------------------------------------------------------
def model_gains(patch):
    """The live values the hand loops take as arguments, read from the patch, after checking
    that its structure is the one hand_string.py and the C loop hard-code."""
    import hand_string as hs
    b = {name: inst.values for name, inst in patch.blocks.items()}
    expected = [
        (b["r1"]["length"], float(hs.D1)), (b["l1"]["length"], float(hs.D1)),
        (b["r2"]["length"], float(hs.D2)), (b["l2"]["length"], float(hs.D2)),
        (tuple(float(c) for c in b["bridge"]["coeffs"]), (0.25, 0.5, 0.25)),
        (round(b["pick"]["duration"] * patch.rate), hs.WIDTH), (b["pick"]["time"], 0.0),
        (patch.rate, 44100.0),
    ]
    for got, want in expected:
        if got != want:
            raise SystemExit(f"{PATCH.name} no longer matches hand_string.py ({got!r} != {want!r})")
    return (b["pick"]["force"], b["bridge"]["gain"], b["nut"]["gain"], b["mic"]["gain"], b["mic"]["pan"])


def throughput(n, reps):
    import numpy as np

    import hand_string as hs
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.patch import load

    patch = load(str(PATCH))
    gains = model_gains(patch)
    start = time.perf_counter()
    first = CompiledKernel(make_program(patch))
    in_process_compile = time.perf_counter() - start
    rec = np.zeros((n, len(first.prog.records)))
    rec.fill(0.0)                                         # prefault
    ext = np.zeros((n, len(getattr(first.prog, "ext_columns", ()))))
    out_hand, out_mirror = np.zeros(n), np.zeros(n)
    out_hand.fill(0.0)
    out_mirror.fill(0.0)
    ring = lambda: np.zeros(128)                          # noqa: E731
    # compile the hand loops (excluded from the timings)
    hs.string_hand(0, 0, out_hand, ring(), ring(), np.zeros(4), ring(), ring(), *gains)
    hs.string_mirror(0, 0, out_mirror, np.zeros(6), ring(), ring(), np.zeros(4), ring(), ring(), *gains)
    out_terms, out_retrig = np.zeros(n), np.zeros(n)
    out_terms.fill(0.0)
    out_retrig.fill(0.0)
    hs.string_hand_delay_terms(0, 0, out_terms, ring(), ring(), np.zeros(4), ring(), ring(), *gains)
    hs.string_hand_retrigger(0, 0, out_retrig, -1e18, ring(), ring(), np.zeros(4), ring(), ring(), *gains)

    def block():
        ck = CompiledKernel(make_program(patch))          # already compiled: fresh state only
        t = time.perf_counter()
        run_kernel(ck, 0, rec, ext)
        return time.perf_counter() - t

    def hand():
        r1, r2, h, l2, l1 = ring(), ring(), np.zeros(4), ring(), ring()
        t = time.perf_counter()
        hs.string_hand(n, 0, out_hand, r1, r2, h, l2, l1, *gains)
        return time.perf_counter() - t

    def mirror():
        state = np.array([-1e18, 0.0, 0.0, 0.0, 0.0, 0.0])
        r1, r2, h, l2, l1 = ring(), ring(), np.zeros(4), ring(), ring()
        t = time.perf_counter()
        hs.string_mirror(n, 0, out_mirror, state, r1, r2, h, l2, l1, *gains)
        return time.perf_counter() - t

    def delay_terms():
        r1, r2, h, l2, l1 = ring(), ring(), np.zeros(4), ring(), ring()
        t = time.perf_counter()
        hs.string_hand_delay_terms(n, 0, out_terms, r1, r2, h, l2, l1, *gains)
        return time.perf_counter() - t

    def retrigger():
        r1, r2, h, l2, l1 = ring(), ring(), np.zeros(4), ring(), ring()
        t = time.perf_counter()
        hs.string_hand_retrigger(n, 0, out_retrig, -1e18, r1, r2, h, l2, l1, *gains)
        return time.perf_counter() - t

    seconds = n / patch.rate

    def via_render():
        r = engine_render(patch, seconds)
        via_render.audio = r.audio
        return r.run_seconds

    chunk = engine_chunk()

    def hand_render():
        out = np.zeros(n)                                 # like render(): fresh, not prefaulted
        r1, r2, h, l2, l1 = ring(), ring(), np.zeros(4), ring(), ring()
        t = time.perf_counter()
        for begin in range(0, n, chunk):
            end = min(n, begin + chunk)
            hs.string_hand(end - begin, begin, out[begin:end], r1, r2, h, l2, l1, *gains)
        elapsed = time.perf_counter() - t
        hand_render.audio = out
        return elapsed

    contenders = {"block": block, "hand": hand, "mirror": mirror, "delay_terms": delay_terms,
                  "retrigger": retrigger, "render": via_render, "hand_render": hand_render}
    best = {k: float("inf") for k in contenders}
    for _ in range(reps):                                 # interleaved, so drift hits all alike
        for name, fn in contenders.items():
            best[name] = min(best[name], fn())
    ref = rec[:, 0]
    diffs = {"hand": np.max(np.abs(out_hand - ref)), "mirror": np.max(np.abs(out_mirror - ref)),
             "delay_terms": np.max(np.abs(out_terms - ref)), "retrigger": np.max(np.abs(out_retrig - ref)),
             "render": np.max(np.abs(via_render.audio[:, 0] - ref)),
             "hand_render": np.max(np.abs(hand_render.audio - ref))}
    return {"n": n, "chunk": chunk, "best": best, "diffs": diffs, "ref": ref, "gains": gains,
            "peak": float(np.max(np.abs(ref))), "in_process_compile": in_process_compile,
            "kernel_path": first.path}


# ---------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------
cpu_model = benchlib.cpu_model


def fmt_compile(r):
    if "error" in r:
        return f"error: {r['error']}"
    return (f"{r['numba_init'] + r['load_compile']:6.3f} s = numba init {r['numba_init']:5.3f} + "
            f"load+compile {r['load_compile']:5.3f} (CompiledKernel {r['kernel']:5.3f});  "
            f"imports {r['import']:4.2f} s, whole process {r['process']:4.2f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="audio rendered per repetition (default 20)")
    ap.add_argument("--reps", type=int, default=15, help="repetitions, the best counts (default 15)")
    ap.add_argument("--quick", action="store_true", help="2 s, 5 repetitions, one cold and one warm compile run")
    ap.add_argument("--no-compile", action="store_true", help="skip the compile-time measurements")
    ap.add_argument("--compile-child", metavar="PATCH", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.compile_child:
        compile_child(args.compile_child)
        return 0
    if args.quick:
        args.seconds, args.reps = 2.0, 5
    sys.path.insert(0, str(HERE))
    import numba
    import numpy as np

    print(f"hapticgraph waveguide-string benchmark, {datetime.date.today().isoformat()}")
    print(f"CPU: {cpu_model()}, {os.cpu_count()} logical CPUs; Python {platform.python_version()}, "
          f"numba {numba.__version__}, numpy {np.__version__}")
    n = int(round(args.seconds * 44100.0))
    with tempfile.TemporaryDirectory(prefix="hg-bench-cache-") as cache:
        os.environ["HAPTICGRAPH_CACHE"] = cache            # this process's kernels: a temp folder
        tp = throughput(n, args.reps)
    ok = True
    c_result, c_out = run_c(n, args.reps, tp["gains"])
    if c_result is not None:
        tp["diffs"]["C"] = float(np.max(np.abs(c_out - tp["ref"])))
        ref_sum = float(np.sum(tp["ref"]))
        if abs(c_result["checksum"] - ref_sum) > 1e-9 * max(1.0, abs(ref_sum)):
            tp["diffs"]["C checksum"] = abs(c_result["checksum"] - ref_sum)
        print(f"C compiler: {c_result['compiler']}")
    else:
        print(f"C loop skipped: {c_out}")

    sps = {k: n / v for k, v in tp["best"].items()}
    print()
    print(f"Throughput: {PATCH.name}, {n} samples ({args.seconds:g} s at 44.1 kHz), best of {args.reps}, "
          f"peak |out| {tp['peak']:.3f}")
    rows = [("block-built kernel (CompiledKernel.run, one call)", sps["block"]),
            ("hand-written numba (hand_string.string_hand)", sps["hand"]),
            ("hand numba mirroring the kernel's arithmetic", sps["mirror"]),
            ("  hand numba + the delay block's 0-coefficient terms", sps["delay_terms"]),
            ("  hand numba + the pluck block's trigger-window test", sps["retrigger"])]
    if c_result is not None:
        rows.append((f"hand-written C ({' '.join(C_FLAGS)})", c_result["samples_per_second"]))
    rows += [(f"engine.render() end to end (run_seconds, chunks of {tp['chunk']})", sps["render"]),
             ("hand numba, render()'s way (same chunks, fresh buffer)", sps["hand_render"])]
    for label, v in rows:
        print(f"  {label:<58} {v / 1e6:8.1f} M samples/s  {1e9 / v:6.2f} ns/sample")
    print()
    print("Outputs against the block-built kernel (max |difference|):")
    for k, d in tp["diffs"].items():
        good = d <= TOLERANCE
        ok &= good
        print(f"  {k:<12} {d:.3g}  {'ok' if good else 'MISMATCH'}")
    print()
    ratio_hand = sps["hand"] / sps["block"]
    print("Ratios (how many times faster the reference is; goal: hand / block <= "
          f"{RATE_GOAL})")
    print(f"  hand numba / block-built        {ratio_hand:5.2f}x  "
          f"{'meets' if ratio_hand <= RATE_GOAL else 'MISSES'} the {RATE_GOAL}x goal")
    print(f"  mirror numba / block-built      {sps['mirror'] / sps['block']:5.2f}x  "
          "(framework overhead alone: the same operations)")
    print(f"  hand numba / mirror numba       {sps['hand'] / sps['mirror']:5.2f}x  "
          "(cost of the general-purpose blocks' arithmetic), of which")
    print(f"    delay block's 0-coefficient terms  {sps['hand'] / sps['delay_terms']:5.2f}x")
    print(f"    pluck block's trigger-window test  {sps['hand'] / sps['retrigger']:5.2f}x")
    if c_result is not None:
        print(f"  C / block-built                 {c_result['samples_per_second'] / sps['block']:5.2f}x")
        print(f"  C / hand numba                  {c_result['samples_per_second'] / sps['hand']:5.2f}x")
    print(f"  hand numba / render() (both via chunks into fresh buffers) "
          f"{sps['hand_render'] / sps['render']:5.2f}x")
    print(f"  (in-process compile of the block-built kernel, numba caches as found: "
          f"{tp['in_process_compile']:.3f} s)")

    if not args.no_compile:
        patches = sorted((REPO / "patches").glob("*.yaml")) + [PATCH]
        cold_runs, warm_runs = (1, 1) if args.quick else (2, 3)
        print()
        print("Compile times in fresh processes, after the imports (goal: cold <= "
              f"{COLD_GOAL} s, warm <= {WARM_GOAL} s, checked on the total = numba's first-use init "
              "+ hapticgraph.load + Program + CompiledKernel); best of "
              f"{cold_runs} cold (new empty HAPTICGRAPH_CACHE and NUMBA_CACHE_DIR each) and {warm_runs} "
              "warm (the same folders again)")
        for path in patches:
            cold, warm = compile_times(path, cold_runs, warm_runs)
            rel = path.relative_to(REPO).as_posix()
            verdict = "error"
            if "error" not in cold and "error" not in warm:
                good = (cold["numba_init"] + cold["load_compile"] <= COLD_GOAL
                        and warm["numba_init"] + warm["load_compile"] <= WARM_GOAL)
                verdict = "ok" if good else "MISSES GOAL"
            print(f"  {rel}  [{verdict}]")
            print(f"    cold {fmt_compile(cold)}")
            print(f"    warm {fmt_compile(warm)}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
