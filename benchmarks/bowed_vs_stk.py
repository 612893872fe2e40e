#!/usr/bin/env python
"""Benchmark: the Fig. 7 bowed string (patches/fig7_bowed_string.yaml) against STK's `Bowed`
instrument, in samples per second. Goal: hapticgraph ≥ 2× STK.

    python benchmarks/bowed_vs_stk.py [--seconds 30] [--reps 7] [--rate 44100]

Needs g++ and STK's headers and library (Debian: `apt-get install -y libstk-dev jackd2
libjack-jackd2-dev`, in ONE apt line, otherwise apt removes one to satisfy the other).
Figures and findings: benchmarks/bowed_vs_stk.md.

hapticgraph: the patch with its rate set to --rate and its hand's script repeated (down-bow,
up-bow, ...: the bow keeps moving for the whole run); load, Program, CompiledKernel (compile time
reported apart), then ONE CompiledKernel.run over all the samples into a prefaulted recording
(left, right and the device force per sample). The simulated device's hand follows its script
inside the kernel; the device's mass, the hand's spring and damper, the bow, the junction and the
string are all integrated there too. Also reported: hapticgraph.graph.engine.render() end to end
(chunks of 16384 samples, the driver receiving the forces between chunks, the output assembled).
STK: a C++ program written to a temporary folder and compiled with g++ -O3 against -lstk:
Stk::setSampleRate, Bowed(50 Hz lowest), noteOn(f, 0.8), then tick() N samples into a prefaulted
buffer, timed inside the program with std::chrono::steady_clock. Bowed::tick and everything it
calls are inline in STK's headers, so they are compiled here at -O3 too.
Both sides play the same pitch (rate / the patch's 100-sample round trip: 441 Hz at 44.1 kHz),
for the same number of samples; the reps alternate between them (so a busy machine slows both
alike) and the median of each counts (the slowest and fastest run are printed beside it).
Nothing is written outside temporary folders (the kernel cache is the user's, as for any
hapticgraph run, unless HAPTICGRAPH_CACHE says otherwise).
"""
import argparse
import json
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
PATCH = HERE.parent / "patches" / "fig7_bowed_string.yaml"
GOAL = 2.0
ROUND_TRIP = 100          # samples: the patch's string (see its header)

CPP = r"""
#include <stk/Bowed.h>
#include <stk/Stk.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

int main(int argc, char **argv) {
  if (argc != 4) { std::fprintf(stderr, "usage: bowed SAMPLES FREQUENCY RATE\n"); return 2; }
  const long n = std::atol(argv[1]);
  const double frequency = std::atof(argv[2]), rate = std::atof(argv[3]);
  stk::Stk::setSampleRate(rate);
  std::vector<double> out(n, 0.0);                 // written once: prefaulted
  stk::Bowed bowed(50.0);
  bowed.noteOn(frequency, 0.8);
  const auto t0 = std::chrono::steady_clock::now();
  for (long i = 0; i < n; i++) out[i] = bowed.tick();
  const auto t1 = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(t1 - t0).count();
  double sq = 0.0;
  bool finite = true;
  for (long i = 0; i < n; i++) { sq += out[i] * out[i]; finite = finite && std::isfinite(out[i]); }
  std::printf("{\"seconds\": %.9g, \"samples\": %ld, \"rms\": %.6g, \"finite\": %s}\n",
              seconds, n, std::sqrt(sq / n), finite ? "true" : "false");
  return 0;
}
"""


def build_stk(folder):
    cxx = shutil.which("g++")
    if cxx is None:
        sys.exit("bowed_vs_stk: g++ not found")
    src = pathlib.Path(folder) / "bowed.cpp"
    exe = pathlib.Path(folder) / "bowed"
    src.write_text(CPP, encoding="utf-8")
    proc = subprocess.run([cxx, "-O3", "-std=c++17", str(src), "-o", str(exe), "-lstk"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("bowed_vs_stk: could not build the STK program (is libstk-dev installed? "
                 "apt-get install -y libstk-dev jackd2 libjack-jackd2-dev):\n" + proc.stderr[-2000:])
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return exe, version


def run_stk(exe, samples, frequency, rate):
    proc = subprocess.run([str(exe), str(samples), repr(frequency), repr(rate)], capture_output=True,
                          text=True, check=True)
    return json.loads(proc.stdout)


def patch_for(rate, folder, device=True):
    """The Fig. 7 patch at `rate`, its hand script repeated back and forth (hold: false); with
    device=False the haptic device is replaced by a constant bow velocity of 0.2 m/s (string and
    bow only, as in STK's Bowed, whose bow velocity comes from an envelope)."""
    text = PATCH.read_text(encoding="utf-8")
    replace = [("rate: 19000\n", f"rate: {rate}\n"),
               ("script: [{t: 0.0, x: -0.16}, {t: 1.6, x: 0.16}]}",
                "script: [{t: 0.0, x: -0.16}, {t: 1.6, x: 0.16}, {t: 3.2, x: -0.16}], hold: false}")]
    if not device:
        replace += [("  hand:   {type: haptic, device: arm}\n", "  hand:   {type: constant, value: 0.2}\n"),
                    ("  - hand.v -> bow.bow_velocity\n", "  - hand.out -> bow.bow_velocity\n"),
                    ("  - react.out -> hand.force\n", "")]
    for old, new in replace:
        if old not in text:
            sys.exit(f"bowed_vs_stk: {PATCH.name} changed; update patch_for()")
        text = text.replace(old, new)
    if not device:
        start = text.index("devices:\n")
        text = text[:start] + text[text.index("blocks:\n"):]
    path = pathlib.Path(folder) / ("fig7_bowed_string.yaml" if device else "fig7_string_and_bow.yaml")
    path.write_text(text, encoding="utf-8")
    return path


class Hapticgraph:
    def __init__(self, path, samples):
        from hapticgraph import load
        self.patch = load(path)
        self.samples = samples

    def kernel_once(self):
        """One fresh program (initial state), one CompiledKernel.run over every sample."""
        from hapticgraph.devices import open_drivers
        from hapticgraph.graph.kernel import CompiledKernel
        from hapticgraph.graph.program import Program
        drivers = open_drivers(self.patch)
        prog = Program(self.patch, (), drivers)
        start = time.perf_counter()
        ck = CompiledKernel(prog)
        compile_seconds = time.perf_counter() - start
        rec = np.empty((self.samples, len(prog.records)))
        rec.fill(0.0)                                           # prefault
        ext = np.zeros((self.samples, len(prog.ext_columns)))
        columns = {}
        for k, (device, _) in enumerate(prog.ext_columns):
            columns.setdefault(device, []).append(k)
        for device, cols in columns.items():
            drivers[device].start(prog.rate)
            drivers[device].fill(0, ext[:, cols[0]: cols[-1] + 1])
        start = time.perf_counter()
        ck.run(0, rec, ext)
        seconds = time.perf_counter() - start
        audio = rec[:, :prog.channels]
        return {"seconds": seconds, "compile_seconds": compile_seconds, "records": len(prog.records),
                "rms": float(np.sqrt(np.mean(audio[:, 0] ** 2))), "finite": bool(np.all(np.isfinite(rec)))}

    def render_once(self):
        from hapticgraph.devices import open_drivers
        from hapticgraph.graph.engine import render
        r = render(self.patch, self.samples / self.patch.rate, drivers=open_drivers(self.patch), progress=False)
        return {"seconds": r.run_seconds}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=30.0, help="audio seconds per run (default 30)")
    ap.add_argument("--reps", type=int, default=7, help="runs of each, the median counts (default 7)")
    ap.add_argument("--rate", type=int, default=44100, help="sample rate (default 44100)")
    ap.add_argument("--json", action="store_true", help="also print the figures as one JSON line")
    args = ap.parse_args(argv)
    samples = int(round(args.seconds * args.rate))
    frequency = args.rate / ROUND_TRIP

    import numba
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bowed-vs-stk-") as folder:
        exe, cxx_version = build_stk(folder)
        hg = Hapticgraph(patch_for(args.rate, folder), samples)
        bare = Hapticgraph(patch_for(args.rate, folder, device=False), samples)
        first = hg.kernel_once()                     # compiles (or loads the cache); not counted
        bare.kernel_once()
        hg.render_once()
        stk_runs, kernel_runs, render_runs, bare_runs = [], [], [], []
        for _ in range(args.reps):
            stk_runs.append(run_stk(exe, samples, frequency, args.rate))
            kernel_runs.append(hg.kernel_once())
            render_runs.append(hg.render_once())
            bare_runs.append(bare.kernel_once())
        for run in stk_runs + kernel_runs + bare_runs:
            if not run["finite"] or not run["rms"] > 1e-6:
                sys.exit(f"bowed_vs_stk: silent or non-finite output: {run}")

    runs = {"stk": stk_runs, "kernel": kernel_runs, "render": render_runs, "bare": bare_runs}
    median = {name: statistics.median(r["seconds"] for r in each) for name, each in runs.items()}
    rate = {name: samples / s for name, s in median.items()}
    spread = {name: f"({samples / max(r['seconds'] for r in each) / 1e6:.2f}-"
                    f"{samples / min(r['seconds'] for r in each) / 1e6:.2f})" for name, each in runs.items()}
    ratio = rate["kernel"] / rate["stk"]
    cpu = benchlib.cpu_model()
    print(f"bowed string, {samples} samples ({args.seconds:g} s at {args.rate} Hz, {frequency:g} Hz), "
          f"median of {args.reps} (slowest-fastest); {cpu}, {os.cpu_count()} CPUs; Python "
          f"{platform.python_version()}, numba {numba.__version__}, {cxx_version}; load average {load[0]:.2f} "
          f"before, {os.getloadavg()[0]:.2f} after")
    print(f"  STK Bowed (g++ -O3, tick() loop)           {rate['stk'] / 1e6:8.2f} M samples/s {spread['stk']}")
    print(f"  hapticgraph kernel (one run, Fig. 7 patch) {rate['kernel'] / 1e6:8.2f} M samples/s {spread['kernel']}"
          f"   ({first['records']} records per sample; first compile/load {first['compile_seconds']:.2f} s)")
    print(f"  hapticgraph render() end to end            {rate['render'] / 1e6:8.2f} M samples/s {spread['render']}"
          f"   ({rate['render'] / rate['stk']:.2f}x STK)")
    print(f"  hapticgraph kernel, string + bow only      {rate['bare'] / 1e6:8.2f} M samples/s {spread['bare']}"
          f"   ({rate['bare'] / rate['stk']:.2f}x STK; the device replaced by a constant bow velocity)")
    print(f"  ratio hapticgraph kernel / STK: {ratio:.2f}x  (goal >= {GOAL:g}x: "
          f"{'met' if ratio >= GOAL else 'NOT met'})")
    if args.json:
        print(json.dumps({"samples": samples, "rate": args.rate, "stk": rate["stk"], "kernel": rate["kernel"],
                          "render": rate["render"], "string_and_bow": rate["bare"], "ratio": ratio, "goal": GOAL}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
