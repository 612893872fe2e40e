"""Sweep throughput (issue 23): variants per second of `hapticgraph sweep` with 1 and 2 worker
processes on 200 one-second variants of a 100-cell lattice string, against a shell loop of
`hapticgraph run --set …` on the same variants (a process and a start-up per variant), and a check
that both make the same audio, sample for sample.

    python benchmarks/sweep.py                 # 200 variants; the shell loop times the first 40
    python benchmarks/sweep.py --variants 50 --shell 10 --workers 1 2

Times are wall-clock: of the whole command (the sweep's includes starting its local cluster and
loading every variant's patch to check it before submitting any), and of the sweep's distributed
phase (its closing note: from the first task submitted to the last row written). The kernel is in
the cache for both sides before anything is timed.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

import soundfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from benchlib import child_env, cpu_model  # noqa: E402

SWEEP = """sweep: 1
patch: string.yaml
seconds: 1.0
sampler: random
seed: 7
count: {count}
axes:
  s.damping: {{min: 0.00001, max: 0.001, scale: log}}
  s.mass: {{min: 0.0008, max: 0.0012}}
  pick.force: {{min: 0.5, max: 1.5}}
features: [f0, t60, centroid, rms, peak]
audio: flac
"""


def _hg(args, env):
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "hapticgraph", *args], env=env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"hapticgraph {' '.join(args)} failed:\n{done.stderr}")
    return time.perf_counter() - start, done.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=200)
    ap.add_argument("--shell", type=int, default=40, help="variants the shell loop renders (its rate is per variant)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    from hapticgraph.sweeps import load_spec
    work = tempfile.mkdtemp(prefix="hg_sweep_bench_")
    try:
        shutil.copy(os.path.join(HERE, "string_100.yaml"), os.path.join(work, "string.yaml"))
        sweep = os.path.join(work, "s.yaml")
        with open(sweep, "w", encoding="utf-8") as f:
            f.write(SWEEP.format(count=args.variants))
        env = child_env(HAPTICGRAPH_CACHE=os.path.join(work, "cache"), HAPTICGRAPH_AOT="0")
        spec = load_spec(sweep)
        _hg(["run", os.path.join(work, "string.yaml"), "--seconds", "0.1", "--out", os.path.join(work, "warm.wav"),
             "--quiet"], env)                                           # the kernel into the cache
        rates, phases = {}, {}
        for n in args.workers:
            seconds, note = _hg(["sweep", sweep, "--out", os.path.join(work, f"out{n}"), "--workers", str(n),
                                 "--quiet"], env)
            rates[n] = args.variants / seconds
            note = note.strip().splitlines()[-1]
            phases[n] = args.variants / float(note.split(" variant(s) in ")[1].split(" s:")[0])
            print(f"sweep, {n} worker(s): {args.variants} variants in {seconds:.1f} s = {rates[n]:.2f} variants/s "
                  f"(whole command); {phases[n]:.2f} variants/s from the first task submitted to the last row")
            print(f"  {note}")
        shell = _shell_loop(spec, work, env, args.shell, os.path.join(work, f"out{args.workers[0]}"))
        print(f"shell loop of `hapticgraph run --set`: {shell:.2f} variants/s ({args.shell} variants)")
        for n, rate in rates.items():
            print(f"  {n} worker(s): {rate / shell:.1f}x the shell loop")
        if 1 in rates and 2 in rates:
            print(f"parallel efficiency 1 -> 2 workers: {rates[2] / (2 * rates[1]):.0%} (whole command), "
                  f"{phases[2] / (2 * phases[1]):.0%} (submitted to last row)")
        print(f"machine: {cpu_model()}, {os.cpu_count()} cores")
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _shell_loop(spec, work, env, count, swept):
    """Variants per second of one `hapticgraph run` per variant; each one's audio must equal the sweep's."""
    start = time.perf_counter()
    for v in spec.variants[:count]:
        sets = [a for o in v.overrides for a in ("--set", o)]
        _hg(["run", spec.patch, "--seconds", repr(spec.seconds), "--out", os.path.join(work, f"shell_{v.id}.flac"),
             "--quiet", *sets], env)
    seconds = time.perf_counter() - start
    for v in spec.variants[:count]:
        a, _ = soundfile.read(os.path.join(work, f"shell_{v.id}.flac"), dtype="int32")
        b, _ = soundfile.read(os.path.join(swept, "audio", f"{v.id}.flac"), dtype="int32")
        if a.shape != b.shape or (a != b).any():
            sys.exit(f"variant {v.id}: the shell loop's audio differs from the sweep's")
    print(f"shell loop and sweep: the same audio for all {count} variants compared, sample for sample")
    return count / seconds


if __name__ == "__main__":
    main()
