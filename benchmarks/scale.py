#!/usr/bin/env python
"""Scale: samples per second against cell count (100 to 1,000,000 cells; 1-D, 2-D, 3-D lattices)
for hapticgraph (kernel alone and whole run) and the C reference, memory per cell, the largest
lattice that runs in real time. Writes benchmarks/scale.png and a table into benchmarks/README.md.

    python benchmarks/scale.py             # every size, median of 3; 5-8 minutes
    python benchmarks/scale.py --quick     # 3 sizes per dimension, one repetition
    python benchmarks/scale.py --no-write  # print only

Each size is a uniform lattice (the parameters of run_all.py's lattice rows: fixed boundary, a
1 ms half-sine pluck on a middle cell, the next cell's position as the sound), rendered for about
1e8 cell-samples (at least 200 samples, at most 1 s of audio):
- hapticgraph kernel: CompiledKernel.run over the render in one call, prefaulted buffer;
- hapticgraph whole run: `hapticgraph run PATCH --seconds S --out X.wav`, warm kernel cache,
  process start to exit (so small lattices show the process's fixed cost);
- C: benchmarks/ref_lattice.c's sample loop (-O3 -march=native), timed inside the program.
Memory per cell: (peak RSS of a whole-run child for the lattice − peak RSS of the same child for a
10-cell lattice) / cells, both rendering 100 samples; for the C reference likewise, from the VmHWM
it prints (a child's ru_maxrss counts its parent's memory at fork, before exec).
Real time: samples/s of the kernel ≥ REALTIME_MARGIN × 44,100 (the audio callback may use at
most half of each period: the issue's p99 load goal), interpolated log-log between sizes.
The first size of each dimension is checked against the C reference (run_all.py's agreement).
"""
import argparse
import datetime
import math
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import run_all
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
BEGIN, END = "<!-- scale:begin -->", "<!-- scale:end -->"
RATE = 44100
REALTIME_MARGIN = 2.0
CELL_SAMPLES = 1e8
SHAPES = {
    "1-D": [[100], [1000], [10000], [100000], [1000000]],
    "2-D": [[10, 10], [32, 32], [100, 100], [316, 316], [1000, 1000]],
    "3-D": [[5, 5, 5], [10, 10, 10], [22, 22, 22], [46, 46, 46], [100, 100, 100]],
}
QUICK = {"1-D": [[100], [10000], [1000000]], "2-D": [[10, 10], [100, 100], [1000, 1000]],
         "3-D": [[5, 5, 5], [22, 22, 22], [100, 100, 100]]}


def cells_of(shape):
    return math.prod(shape)


def write_patch(folder, shape):
    """A lattice patch; returns (path, exciter flat index, mic flat index)."""
    exc_idx = [s // 2 for s in shape[:-1]] + [shape[-1] // 3]
    mic_idx = exc_idx[:-1] + [exc_idx[-1] + 1]
    flat = lambda idx: int(np.ravel_multi_index(idx, shape))
    path = folder / f"lattice_{'x'.join(map(str, shape))}.yaml"
    path.write_text(
        f"hapticgraph: 1\nname: lattice {'x'.join(map(str, shape))}\nrate: {RATE}\nblocks:\n"
        f"  s: {{type: lattice, shape: {shape}, mass: {run_all.MASS}, tension: {run_all.TENSION}, "
        f"damping: {run_all.DAMPING}}}\n"
        f"  pick: {{type: pluck, time: 0.0, force: {run_all.PLUCK_FORCE}, duration: 0.001}}\n"
        f"  out: {{type: audio_out, channels: 1}}\n"
        f"connect:\n  - pick.out -> s{exc_idx}.force\n  - s{mic_idx}.position -> out.ch0\n", encoding="utf-8")
    return path, flat(exc_idx), flat(mic_idx)


# A small parent that forks and execs the command: a child's ru_maxrss counts the memory it had
# at fork time (the parent's copy, before exec), so the child must not be forked from this
# process (hundreds of MB with numba loaded). The wrapper's own few MB cancel in the baseline.
WRAPPER = """import os, sys
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    os.execvp(sys.argv[1], sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
print(usage.ru_maxrss if os.waitstatus_to_exitcode(status) == 0 else -1)
"""


def peak_rss(cmd, env):
    """Peak resident set of a child process, bytes (ru_maxrss via wait4 in a small wrapper)."""
    proc = subprocess.run([sys.executable, "-c", WRAPPER, *map(str, cmd)], env=env, capture_output=True,
                          text=True, check=True)
    kib = int(proc.stdout.split()[-1])
    if kib < 0:
        sys.exit(f"scale: {' '.join(map(str, cmd))} failed")
    return kib * 1024


def c_peak(cmd, env):
    """The C reference's own peak resident set (VmHWM, which it prints), bytes: small enough that
    a wrapper's memory at fork would hide it."""
    out = run_all.timed(cmd, env)[1]
    return next(int(line.split()[1]) for line in out.splitlines() if line.startswith("peak_rss_kib")) * 1024


def commands(exe, folder, shape, samples):
    path, exc, mic = write_patch(folder, shape)
    wav = folder / "out.wav"
    hg = run_all.hg_command(path, samples / RATE, wav)
    c = run_all.ref_command({"lattice": exe}, ("lattice", "x".join(map(str, shape)), exc, mic), samples, RATE, wav)
    return path, hg, c


def measure_size(args, exe, folder, env, dim, shape):
    cells = cells_of(shape)
    samples = int(min(RATE, max(200, CELL_SAMPLES / cells)))
    if args.quick:
        samples = max(100, samples // 10)
    path, hg, c = commands(exe, folder, shape, samples)
    run_all.timed(run_all.hg_command(path, 100 / RATE, folder / "warm.wav"), env)   # compile: cache warm
    kernel, whole, loop = [], [], []
    for _ in range(args.reps):
        kernel.append(run_all.kernel_run(path, samples)[0])
        whole.append(run_all.timed(hg, env)[0])
        loop.append(run_all.loop_seconds(run_all.timed(c, env)[1]))
    row = {"dim": dim, "shape": shape, "cells": cells, "samples": samples,
           "kernel": samples / statistics.median(kernel), "whole": samples / statistics.median(whole),
           "c": samples / statistics.median(loop), "hg_bytes": None, "c_bytes": None}
    if cells >= 10000:
        _, hg_m, c_m = commands(exe, folder, shape, 100)
        _, hg_0, c_0 = commands(exe, folder, [10], 100)
        run_all.timed(hg_0, env)                                                      # its kernel, cached
        row["hg_bytes"] = (peak_rss(hg_m, env) - peak_rss(hg_0, env)) / cells
        row["c_bytes"] = (c_peak(c_m, env) - c_peak(c_0, env)) / cells
    print(f"  {dim} {'x'.join(map(str, shape)):>13} {cells:8d} cells: kernel {row['kernel']:10.0f}, whole "
          f"{row['whole']:10.0f}, C {row['c']:10.0f} samples/s", file=sys.stderr, flush=True)
    return row


def agreement(exe, folder, shape):
    path, exc, mic = write_patch(folder, shape)
    ours = run_all.kernel_run(path, run_all.AGREE_SAMPLES)[1]
    dump = folder / "agree.f64"
    run_all.timed(run_all.ref_command({"lattice": exe}, ("lattice", "x".join(map(str, shape)), exc, mic),
                                      run_all.AGREE_SAMPLES, RATE, folder / "agree.wav", dump))
    theirs = np.fromfile(dump, dtype=np.float64)
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(ours)))


def realtime(rows, key, need):
    """Largest cell count with rows[key] ≥ need: (largest measured size meeting it, log-log estimate)."""
    rows = sorted(rows, key=lambda r: r["cells"])
    ok = [r for r in rows if r[key] >= need]
    if not ok:
        return None, None
    best = ok[-1]
    after = next((r for r in rows if r["cells"] > best["cells"]), None)
    if after is None:
        return best, None
    x0, x1 = math.log(best["cells"]), math.log(after["cells"])
    y0, y1 = math.log(best[key]), math.log(after[key])
    return best, math.exp(x0 + (math.log(need) - y0) * (x1 - x0) / (y1 - y0))


def plot(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 9), height_ratios=[2, 1])
    colours = {"1-D": "tab:blue", "2-D": "tab:orange", "3-D": "tab:green"}
    for dim, colour in colours.items():
        rs = sorted((r for r in rows if r["dim"] == dim), key=lambda r: r["cells"])
        x = [r["cells"] for r in rs]
        top.plot(x, [r["kernel"] for r in rs], "-o", color=colour, label=f"{dim} hapticgraph kernel")
        top.plot(x, [r["whole"] for r in rs], ":^", color=colour, label=f"{dim} hapticgraph whole run")
        top.plot(x, [r["c"] for r in rs], "--s", color=colour, label=f"{dim} C reference")
        mem = [r for r in rs if r["hg_bytes"] is not None]
        bottom.plot([r["cells"] for r in mem], [r["hg_bytes"] for r in mem], "-o", color=colour,
                    label=f"{dim} hapticgraph")
        bottom.plot([r["cells"] for r in mem], [r["c_bytes"] for r in mem], "--s", color=colour, label=f"{dim} C")
    top.axhline(RATE, color="k", lw=0.8)
    top.axhline(REALTIME_MARGIN * RATE, color="k", lw=0.8, ls="--")
    top.text(110, RATE * 0.75, "44,100 samples/s", fontsize=8)
    top.text(110, REALTIME_MARGIN * RATE * 1.15, f"real time with margin {REALTIME_MARGIN:g}×", fontsize=8)
    top.set(xscale="log", yscale="log", xlabel="cells", ylabel="samples / s",
            title="Mass-spring lattices: samples per second against size")
    top.legend(fontsize=7, ncol=3)
    top.grid(True, which="both", lw=0.3)
    bottom.set(xscale="log", xlabel="cells", ylabel="bytes per cell (peak RSS growth)")
    bottom.legend(fontsize=7, ncol=3)
    bottom.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def table(rows, args, agreements, versions):
    lines = [(f"Measured {datetime.date.today()} at commit `{run_all.commit()}` with "
              f"`python benchmarks/scale.py{' --quick' if args.quick else ''}` (median of {args.reps}), on "
              f"{run_all.machine(versions)}. Plot: [`scale.png`](scale.png)."), "",
             ("| lattice | cells | samples | hapticgraph kernel | whole run | C reference | kernel / C | "
              "bytes per cell, hapticgraph / C |"),
             "|---|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        mem = "—" if r["hg_bytes"] is None else f"{r['hg_bytes']:.0f} / {r['c_bytes']:.0f}"
        lines.append(f"| {r['dim']} {'×'.join(map(str, r['shape']))} | {r['cells']:,} | {r['samples']:,} | "
                     f"{r['kernel']:,.0f} | {r['whole']:,.0f} | {r['c']:,.0f} | {r['kernel'] / r['c']:.2f}× | {mem} |")
    agree = ", ".join(f"{d} {a:.1e} of the peak" for d, a in agreements.items())
    lines += ["", ("Samples per second. Agreement of the C reference with hapticgraph on the first 4,410 samples "
                   f"of the smallest lattice: {agree}."), "",
              (f"Largest lattice in real time (kernel samples/s ≥ {REALTIME_MARGIN:g} × 44,100 = "
               f"{REALTIME_MARGIN * RATE:,.0f}, i.e. at most half of each audio period; estimate interpolated "
               "log-log between the measured sizes):"), ""]
    for dim in SHAPES:
        rs = [r for r in rows if r["dim"] == dim]
        parts = []
        for key, name in (("kernel", "hapticgraph"), ("c", "C")):
            best, estimate = realtime(rs, key, REALTIME_MARGIN * RATE)
            bare, bare_estimate = realtime(rs, key, RATE)
            text = "none measured" if best is None else f"{best['cells']:,} cells measured"
            if estimate:
                text += f", about {estimate:,.0f} estimated"
            if bare_estimate or bare:
                text += f" (without margin: about {(bare_estimate or bare['cells']):,.0f})"
            parts.append(f"{name} {text}")
        lines.append(f"- {dim}: " + "; ".join(parts) + ".")
    return "\n".join(lines)


def write_readme(text):
    readme = run_all.README
    old = readme.read_text(encoding="utf-8")
    if BEGIN not in old or END not in old:
        sys.exit(f"scale: {readme.name} has no {BEGIN} … {END} markers")
    head, rest = old.split(BEGIN, 1)
    readme.write_text(head + BEGIN + "\n" + text + "\n" + END + rest.split(END, 1)[1], encoding="utf-8")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=None, help="repetitions, median counts (default 3, quick 1)")
    ap.add_argument("--quick", action="store_true", help="3 sizes per dimension, shorter renders")
    ap.add_argument("--no-write", action="store_true", help="print only: no README table, no PNG")
    args = ap.parse_args(argv)
    args.reps = args.reps or (1 if args.quick else 3)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hg-scale-") as folder:
        folder = pathlib.Path(folder)
        exes, versions = run_all.build(folder)
        env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / "cache"))
        os.environ["HAPTICGRAPH_CACHE"] = env["HAPTICGRAPH_CACHE"]
        shapes = QUICK if args.quick else SHAPES
        agreements = {dim: agreement(exes["lattice"], folder, sizes[0]) for dim, sizes in shapes.items()}
        rows = [measure_size(args, exes["lattice"], folder, env, dim, shape)
                for dim, sizes in shapes.items() for shape in sizes]
    text = table(rows, args, agreements, versions)
    print(text)
    print(f"({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    if not args.no_write:
        plot(rows, HERE / "scale.png")
        write_readme(text)
    return 1 if any(not a <= run_all.RELATIVE_TOLERANCE for a in agreements.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
