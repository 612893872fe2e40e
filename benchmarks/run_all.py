#!/usr/bin/env python
"""Every headline benchmark row in ONE process, interleaved, median of --reps: hapticgraph against
natural C and STK, whole program and kernel alone. Writes the table into benchmarks/README.md.

    python benchmarks/run_all.py            # full run, 5 repetitions, about 3 minutes
    python benchmarks/run_all.py --quick    # smoke run: short renders, 3 repetitions, about 1 minute
    python benchmarks/run_all.py --no-write # print the table only

Each row renders one patch. Whole run (the headline): `hapticgraph run PATCH --seconds S --out
X.wav` as a user runs it, a fresh process with the kernel cache warm (one untimed run first, in a
temporary HAPTICGRAPH_CACHE), timed from process start to exit (WAV written), against the whole
reference program, compiled beforehand, also timed from process start to exit (WAV written).
Kernel alone: `CompiledKernel.run` over the whole render in one call, into a prefaulted buffer,
the simulated device's inputs computed beforehand, against the reference's own sample loop (timed
inside it, its output buffer prefaulted). Marginal (issue 25's measure, so that start-up cancels):
the whole run of the long render minus the whole run of a SHORT_SECONDS render, each side. Short
run: that SHORT_SECONDS render alone, process start to exit (issue 25: ≤ 0.35 s). Ratio =
hapticgraph speed / reference speed (> 1: faster); goals are on the marginal ratio.

References (benchmarks/ref_*.c, ref_bowed.cpp), compiled with -O3 -march=native and compiler
defaults (FMA contraction allowed): ref_lattice.c (a two-level FDTD, one pass per sample),
ref_waveguide.c (the loop of hand_string.string_hand), ref_bowed.cpp (STK's own Bowed class).
Before timing, each lattice and waveguide reference is checked against hapticgraph's kernel on the
first AGREE_SAMPLES samples of the same patch (see agree()); the bowed row cannot be (STK's Bowed
is another model), its output is checked to be finite and sounding.
Exit status 1 if an agreement check fails.
"""
import argparse
import datetime
import os
import pathlib
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
README = HERE / "README.md"
BEGIN, END = "<!-- run_all:begin -->", "<!-- run_all:end -->"
FLAGS = ["-O3", "-march=native"]
AGREE_SAMPLES = 4410
# The reference's arithmetic differs from hapticgraph's in rounding only (the FDTD eliminates the
# velocity, so it sums other terms in another order; gcc contracts a*b+c into FMAs): a few ulps
# per operation per sample, which the scheme's cancellation (A*u - B*u_prev with A, B near 1 and 2)
# amplifies in the small differences that make the signal. Measured at commit 60de0ee over the first
# 4,410 samples: 0 (waveguide) to 1.3e-10 (30,000-cell string) of the peak. Any difference in the
# model (a cell index off by one, the pluck one sample late, a parameter off by 1e-6) gives 1e-6 of
# the peak or more; 1e-8 lies between, with a margin of ~100 on each side.
RELATIVE_TOLERANCE = 1e-8
SHORT_SECONDS = 0.5         # the short render: what start-up costs, and what the marginal rate subtracts
SHORT_GOAL = 0.35           # issue 25: a whole short run of a cached patch, seconds

# (label, patch, seconds full, seconds quick, reference, goal for the whole run)
ROWS = [
    ("1-D string, 100 cells", "string_100.yaml", 300.0, 15.0, ("lattice", "100", 30, 33), 0.8),
    ("1-D string, 30,000 cells", "string_30000.yaml", 2.0, 0.1, ("lattice", "30000", 10000, 10003), 1.0),
    ("2-D sheet, 32 x 32", "sheet_32.yaml", 20.0, 1.0, ("lattice", "32x32", 10 * 32 + 12, 11 * 32 + 13), 0.8),
    ("2-D sheet, 150 x 150", "sheet_150.yaml", 2.0, 0.1, ("lattice", "150x150", 50 * 150 + 60, 51 * 150 + 61), 1.0),
    ("Fig. 7 bowed string, simulated device (vs STK Bowed)", "fig7", 600.0, 20.0, ("stk",), 2.0),
    ("waveguide string", "waveguide_string.yaml", 600.0, 20.0, ("waveguide",), None),
]
MASS, TENSION, DAMPING, PLUCK_WIDTH, PLUCK_FORCE = 0.001, 100000.0, 0.0001, 44, 1.0


def fig7_patch(folder):
    """patches/fig7_bowed_string.yaml with its hand's script repeated (hold: false), so the bow
    keeps moving (down-bow, up-bow, ...) for the whole render; everything else as shipped."""
    text = (HERE.parent / "patches" / "fig7_bowed_string.yaml").read_text(encoding="utf-8")
    old = "script: [{t: 0.0, x: -0.16}, {t: 1.6, x: 0.16}]}"
    if old not in text:
        sys.exit("run_all: patches/fig7_bowed_string.yaml changed; update fig7_patch()")
    path = folder / "fig7_bowed_string_moving.yaml"
    path.write_text(text.replace(old, "script: [{t: 0.0, x: -0.16}, {t: 1.6, x: 0.16}, {t: 3.2, x: -0.16}],"
                                      " hold: false}"), encoding="utf-8")
    return path


# ---------------------------------------------------------------------------------------------
# the references
# ---------------------------------------------------------------------------------------------
def build(folder):
    """Compile the three references; {name: executable}, and the compilers' versions."""
    cc, cxx = shutil.which("gcc") or shutil.which("cc"), shutil.which("g++")
    if cc is None or cxx is None:
        sys.exit("run_all: needs gcc and g++ (and libstk-dev for the bowed row)")
    exes = {}
    for name, compiler, src, libs in (("lattice", cc, "ref_lattice.c", ["-lm"]),
                                      ("waveguide", cc, "ref_waveguide.c", ["-lm"]),
                                      ("stk", cxx, "ref_bowed.cpp", ["-lstk"])):
        exe = folder / name
        proc = subprocess.run([compiler, *FLAGS, str(HERE / src), "-o", str(exe), *libs],
                              check=False, capture_output=True, text=True)
        if proc.returncode != 0:
            sys.exit(f"run_all: cannot build {src}:\n{proc.stderr[-2000:]}")
        exes[name] = exe
    versions = [subprocess.run([c, "--version"], check=False, capture_output=True, text=True).stdout.splitlines()[0]
                for c in (cc, cxx)]
    return exes, versions


def ref_command(exes, ref, samples, rate, wav, dump=None):
    if ref[0] == "lattice":
        _, shape, exc, mic = ref
        cmd = [exes["lattice"], shape, repr(MASS), repr(TENSION), repr(DAMPING), str(rate), str(samples),
               str(exc), str(mic), "0", str(PLUCK_WIDTH), repr(PLUCK_FORCE), wav]
    elif ref[0] == "waveguide":
        cmd = [exes["waveguide"], str(samples), wav]
    else:
        cmd = [exes["stk"], str(samples), str(rate), repr(rate / 100.0), wav]   # the patch's 100-sample loop
    return [str(c) for c in cmd] + ([str(dump)] if dump else [])


def timed(cmd, env=None):
    """Wall seconds of a child process from start to exit, and its standard output."""
    start = time.perf_counter()
    proc = subprocess.run(cmd, check=False, capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"run_all: {' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return seconds, proc.stdout


def loop_seconds(stdout):
    return next(float(line.split()[1]) for line in stdout.splitlines() if line.startswith("loop_seconds"))


# ---------------------------------------------------------------------------------------------
# hapticgraph
# ---------------------------------------------------------------------------------------------
def hg_command(patch, seconds, wav):
    exe = pathlib.Path(sys.executable).with_name("hapticgraph")
    head = [str(exe)] if exe.exists() else [sys.executable, "-m", "hapticgraph"]
    return head + ["run", str(patch), "--seconds", repr(seconds), "--out", str(wav)]


def kernel_run(patch_path, samples):
    """(seconds of ONE CompiledKernel.run over `samples`, audio channel 0 as float64)."""
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.kernel import CompiledKernel
    from hapticgraph.graph.program import Program

    from hapticgraph import load
    patch = load(str(patch_path))
    drivers = open_drivers(patch)
    prog = Program(patch, (), drivers)
    ck = CompiledKernel(prog)
    rec = np.empty((samples, len(prog.records)))
    rec.fill(0.0)                                            # prefault
    ext = np.zeros((samples, len(prog.ext_columns)))
    columns = {}
    for k, (device, _) in enumerate(prog.ext_columns):
        columns.setdefault(device, []).append(k)
    for device, cols in columns.items():                     # the simulated hand, computed beforehand
        drivers[device].start(prog.rate)
        drivers[device].fill(0, ext[:, cols[0]: cols[-1] + 1])
    start = time.perf_counter()
    ck.run(0, rec, ext)
    seconds = time.perf_counter() - start
    return seconds, rec[:, 0].copy()


def patch_rate(patch_path):
    from hapticgraph import load
    return int(load(str(patch_path)).rate)


# ---------------------------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------------------------
def agree(row, patch, exes, rate, folder):
    """max |hapticgraph − reference| / peak over the first AGREE_SAMPLES samples (None: bowed row)."""
    ref = row[4]
    if ref[0] == "stk":
        return None
    _, ours = kernel_run(patch, AGREE_SAMPLES)
    dump = folder / "agree.f64"
    timed(ref_command(exes, ref, AGREE_SAMPLES, rate, folder / "agree.wav", dump))
    theirs = np.fromfile(dump, dtype=np.float64)
    peak = float(np.max(np.abs(ours)))
    if not peak > 0.0:
        sys.exit(f"run_all: {row[0]}: silent over the first {AGREE_SAMPLES} samples")
    return float(np.max(np.abs(ours - theirs))) / peak


def measure(args, folder):
    exes, versions = build(folder)
    env = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / "cache"))
    os.environ["HAPTICGRAPH_CACHE"] = env["HAPTICGRAPH_CACHE"]        # the user's cache stays untouched
    rows = []
    for row in ROWS:
        patch = fig7_patch(folder) if row[1] == "fig7" else HERE / row[1]
        seconds = row[3] if args.quick else row[2]
        rate = patch_rate(patch)
        timed(hg_command(patch, min(seconds, 0.1), folder / "warm.wav"), env)   # compile: cache warm
        rows.append({"label": row[0], "patch": patch, "seconds": seconds, "rate": rate, "ref": row[4],
                     "goal": row[5], "samples": round(seconds * rate),
                     "agree": agree(row, patch, exes, rate, folder),
                     "hg_whole": [], "ref_whole": [], "hg_kernel": [], "ref_loop": [], "hg_short": [],
                     "ref_short": []})
    for rep in range(args.reps):                              # interleaved: load hits every row alike
        for r in rows:
            wav = folder / "out.wav"
            pair = [("hg", hg_command(r["patch"], r["seconds"], wav)),
                    ("ref", ref_command(exes, r["ref"], r["samples"], r["rate"], wav))]
            short = round(min(SHORT_SECONDS, r["seconds"] / 2) * r["rate"])    # --quick: half the render
            pair += [("hg_short", hg_command(r["patch"], short / r["rate"], wav)),
                     ("ref_short", ref_command(exes, r["ref"], short, r["rate"], wav))]
            for side, cmd in (pair if rep % 2 == 0 else pair[::-1]):
                seconds, stdout = timed(cmd, env)
                if side == "ref":
                    r["ref_loop"].append(loop_seconds(stdout))
                r[{"hg": "hg_whole", "ref": "ref_whole"}.get(side, side)].append(seconds)
            seconds, audio = kernel_run(r["patch"], r["samples"])
            if not (np.all(np.isfinite(audio)) and np.any(audio != 0.0)):
                sys.exit(f"run_all: {r['label']}: silent or non-finite output")
            r["hg_kernel"].append(seconds)
            print(f"  rep {rep + 1}/{args.reps} {r['label']}: whole {seconds_text(r['hg_whole'][-1])} vs "
                  f"{seconds_text(r['ref_whole'][-1])}, kernel {seconds_text(seconds)} vs "
                  f"{seconds_text(r['ref_loop'][-1])}", file=sys.stderr, flush=True)
    for r in rows:
        for key in ("hg_whole", "ref_whole", "hg_kernel", "ref_loop", "hg_short", "ref_short"):
            r[key] = statistics.median(r[key])
    return rows, versions


def seconds_text(s):
    return f"{s:.3f} s"


def machine(versions):
    cpu = benchlib.cpu_model()
    import numba
    return (f"{cpu}, {os.cpu_count()} CPUs; Python {platform.python_version()}, numba {numba.__version__}, "
            f"numpy {np.__version__}; {versions[0]}; {versions[1]}")


def commit():
    proc = subprocess.run(["git", "-C", str(HERE), "rev-parse", "--short", "HEAD"], check=False, capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", str(HERE), "status", "--porcelain", "--untracked-files=no", "--", "graph",
                            "blocks", "devices", "hapticgraph"], check=False, capture_output=True, text=True).stdout.strip()
    return (proc.stdout.strip() or "unknown") + (" (library modified)" if dirty else "")


def table(rows, args, versions):
    lines = [(f"Measured {datetime.date.today()} at commit `{commit()}` with "
              f"`python benchmarks/run_all.py{' --quick' if args.quick else ''}` "
              f"(median of {args.reps}, rows interleaved), on {machine(versions)}."), "",
             (f"| row | render | whole run: hapticgraph / reference | ratio | marginal (render − {SHORT_SECONDS:g} s "
              f"render): hapticgraph / reference | ratio | {SHORT_SECONDS:g} s render, whole: hapticgraph / reference "
              "| kernel alone: hapticgraph / reference, M samples/s | ratio | goal (marginal) | agreement |"),
             "|---|---|---|---:|---|---:|---|---|---:|---|---|"]
    for r in rows:
        whole = r["ref_whole"] / r["hg_whole"]
        hg_marginal, ref_marginal = r["hg_whole"] - r["hg_short"], r["ref_whole"] - r["ref_short"]
        marginal = ref_marginal / hg_marginal
        kernel = r["ref_loop"] / r["hg_kernel"]
        goal = "—" if r["goal"] is None else (f"≥ {r['goal']:g}×: " + ("met" if marginal >= r["goal"] else "**not met**"))
        short = f"{r['hg_short']:.2f} s / {r['ref_short']:.2f} s" + (" (≤ 0.35 s: met)" if r["hg_short"] <= SHORT_GOAL
                                                                     else " (≤ 0.35 s: **not met**)")
        agreement = ("STK Bowed is another model: finite, sounding" if r["agree"] is None
                     else f"{r['agree']:.1e} of peak")
        lines.append(f"| {r['label']} | {r['seconds']:g} s at {r['rate']} Hz | {r['hg_whole']:.2f} s / "
                     f"{r['ref_whole']:.2f} s | {whole:.2f}× | {hg_marginal:.2f} s / {ref_marginal:.2f} s | "
                     f"**{marginal:.2f}×** | {short} | {r['samples'] / r['hg_kernel'] / 1e6:.3g} / "
                     f"{r['samples'] / r['ref_loop'] / 1e6:.3g} | {kernel:.2f}× | {goal} | {agreement} |")
    return "\n".join(lines)


def write_readme(text):
    old = README.read_text(encoding="utf-8")
    if BEGIN not in old or END not in old:
        sys.exit(f"run_all: {README.name} has no {BEGIN} … {END} markers")
    head, rest = old.split(BEGIN, 1)
    README.write_text(head + BEGIN + "\n" + text + "\n" + END + rest.split(END, 1)[1], encoding="utf-8")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=None, help="repetitions, median counts (default 5, quick 3)")
    ap.add_argument("--quick", action="store_true", help="short renders, 3 repetitions: a smoke run")
    ap.add_argument("--no-write", action="store_true", help="print the table, leave README.md alone")
    args = ap.parse_args(argv)
    args.reps = max(3, args.reps or (3 if args.quick else 5))
    with tempfile.TemporaryDirectory(prefix="hg-run-all-") as folder:
        rows, versions = measure(args, pathlib.Path(folder))
    text = table(rows, args, versions)
    print(text)
    if not args.no_write:
        write_readme(text)
    bad = [r["label"] for r in rows if r["agree"] is not None and not r["agree"] <= RELATIVE_TOLERANCE]
    if bad:
        print(f"run_all: the reference disagrees with hapticgraph beyond {RELATIVE_TOLERANCE:g} of the peak: "
              f"{', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
