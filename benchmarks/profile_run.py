#!/usr/bin/env python
"""Where the time of a whole `hapticgraph run` goes: the stages of one warm run, from cProfile.

    python benchmarks/profile_run.py PATCH --seconds S

Runs `hapticgraph run PATCH --seconds S --out X.wav` three times in fresh processes (a temporary
HAPTICGRAPH_CACHE: the first run fills it, untimed), the second plain (its wall time is the
figure a user sees), the third under cProfile, and prints the cumulative seconds of each stage
under the profiler. cProfile slows pure-Python code (imports, planning) more than the compiled
kernel or numpy, so the stages are given as shares of the profiled total beside the plain wall
time; interpreter start-up (before cProfile starts) is timed apart with `python -c pass`.
"""
import argparse
import os
import pathlib
import pstats
import subprocess
import sys
import tempfile
import time

# (stage, file suffix, function name): cumulative time of that function under cProfile
STAGES = [
    ("the command's imports (numpy, PyYAML, soundfile, hapticgraph: cli._command)", "hapticgraph/cli.py", "_command"),
    ("patch load (schema verdict or check, plugins, checks)", "graph/patch.py", "load"),
    ("  of which the JSON Schema check (whole_errors: a patch not found clean before)", "graph/explain.py",
     "whole_errors"),
    ("drivers opened (open_drivers)", "devices/opening.py", "open_drivers"),
    ("Program (plan, networks)", "graph/program.py", "__init__"),
    ("CompiledKernel (code generation, cache verified, module loaded)", "graph/kernel.py", "__init__"),
    ("  of which numba's cache load (JIT kernels: HAPTICGRAPH_AOT=0)", "numba/core/caching.py", "load_overload"),
    ("render loop (_stream)", "graph/engine.py", "_stream"),
    ("  kernel (CompiledKernel.run)", "graph/kernel.py", "run"),
    ("  simulated device: fill inputs", "devices/simulated.py", "fill"),
    ("  simulated device: send forces", "devices/simulated.py", "send"),
    ("  WAV writing (FileSink.write)", "devices/files.py", "write"),
    ("WAV closing (FileSink.close)", "devices/files.py", "close"),
]


def hg(patch, seconds, wav, env, profile=None):
    exe = pathlib.Path(sys.executable).with_name("hapticgraph")
    cmd = [sys.executable, "-m", "cProfile", "-o", str(profile), str(exe)] if profile else [str(exe)]
    start = time.perf_counter()
    subprocess.run(cmd + ["run", str(patch), "--seconds", repr(seconds), "--out", str(wav), "--quiet"],
                   check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def stages(profile):
    stats = pstats.Stats(str(profile)).stats
    total = max(ct for (_, _, _), (_, _, _, ct, _) in stats.items())
    rows = []
    for label, suffix, name in STAGES:
        ct = sum(v[3] for (f, _, fn), v in stats.items() if fn == name and f.replace(os.sep, "/").endswith(suffix))
        rows.append((label, ct))
    return total, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("patch")
    ap.add_argument("--seconds", type=float, default=2.0)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hg-profile-") as folder:
        folder = pathlib.Path(folder)
        env = dict(os.environ, HAPTICGRAPH_CACHE=str(folder / "cache"))
        wav = folder / "out.wav"
        hg(args.patch, min(args.seconds, 0.1), wav, env)                       # fills the cache
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], check=True)
        bare = time.perf_counter() - start
        wall = hg(args.patch, args.seconds, wav, env)
        hg(args.patch, args.seconds, wav, env, profile=folder / "run.prof")
        total, rows = stages(folder / "run.prof")
    print(f"{args.patch}, {args.seconds:g} s: whole run {wall:.2f} s (warm cache); interpreter start-up "
          f"(python -c pass) {bare:.2f} s; under cProfile {total:.2f} s, of which:")
    for label, ct in rows:
        print(f"  {label:66} {ct:6.2f} s  {100 * ct / total:5.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
