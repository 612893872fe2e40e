#!/usr/bin/env python
"""The Fig. 7 row of run_all.py alone, and where its render loop's time goes; optionally for
several installs of hapticgraph at once, interleaved (before and after a change).

    python benchmarks/fig7_row.py                      # 600 s at 19 kHz, median of 5
    python benchmarks/fig7_row.py --quick              # 20 s, median of 3
    python benchmarks/fig7_row.py --python A/bin/python --python B/bin/python   # compare installs

Per repetition and install, in turn (the installs alternate which goes first, STK between):
- whole run: `hapticgraph run PATCH --seconds S --out X.wav` in a fresh process, kernel cache warm
  (run_all.py's headline figure), against STK's Bowed (ref_bowed.cpp), process start to exit;
- kernel alone: one CompiledKernel.run over the whole render (run_all.kernel_run);
- render loop: engine.stream into a sink that keeps nothing, with the time spent in the kernel
  (runner.run) and in the drivers (fill + send) summed apart: the drivers' share of the loop.
The patch is run_all.fig7_patch's: patches/fig7_bowed_string.yaml with the hand's script
repeated (hold: false), so the simulated device keeps moving the bow.
"""
import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import benchlib  # noqa: E402
import run_all  # noqa: E402


def loop_child(patch, seconds):
    """Time one engine.stream of the patch: (loop seconds, kernel seconds, driver seconds)."""
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph import engine

    patch = load(str(patch))
    drivers = open_drivers(patch)
    spent = {"kernel": 0.0, "drivers": 0.0}

    def timed_call(fn, key):
        def call(*args):
            start = time.perf_counter()
            fn(*args)
            spent[key] += time.perf_counter() - start
        return call

    for d in drivers.values():
        d.fill, d.send = timed_call(d.fill, "drivers"), timed_call(d.send, "drivers")
    make = engine.make_engine

    def runner(prog, which="compiled"):
        r = make(prog, which)
        r.run = timed_call(r.run, "kernel")
        return r
    engine.make_engine = runner

    class Null:
        def start(self, *args):
            pass

        def write(self, block):
            pass

    out = engine.stream(patch, seconds, Null(), drivers=drivers)
    return {"loop": out.run_seconds, **spent}


def child(argv):
    what, patch, amount = argv[0], argv[1], float(argv[2])
    if what == "--kernel-child":
        seconds, audio = run_all.kernel_run(patch, int(amount))
        assert audio.any()
        print(json.dumps({"kernel_alone": seconds}))
    else:
        print(json.dumps(loop_child(patch, amount)))


def py_run(python, args, env):
    proc = subprocess.run([python, str(pathlib.Path(__file__).resolve()), *args], check=True,
                          capture_output=True, text=True, env=env)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def hg_exe(python):
    exe = pathlib.Path(python).with_name("hapticgraph")
    return [str(exe)] if exe.exists() else [python, "-m", "hapticgraph"]


def measure(args, folder):
    exes, _ = run_all.build(folder)
    patch = run_all.fig7_patch(folder)
    rate = run_all.patch_rate(patch)
    samples = round(args.seconds * rate)
    envs = {}
    for k, py in enumerate(args.python):
        envs[py] = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / f"cache{k}"))
        run_all.timed(hg_exe(py) + ["run", str(patch), "--seconds", "0.1", "--out", str(folder / "w.wav")], envs[py])
    res = {py: {"whole": [], "kernel_alone": [], "loop": [], "kernel": [], "drivers": []} for py in args.python}
    stk = []
    wav = folder / "out.wav"
    for rep in range(args.reps):
        order = args.python if rep % 2 == 0 else args.python[::-1]
        for k, py in enumerate(order):
            if k == len(order) // 2:
                stk.append(run_all.timed(run_all.ref_command(exes, ("stk",), samples, rate, wav))[0])
            cmd = hg_exe(py) + ["run", str(patch), "--seconds", repr(args.seconds), "--out", str(wav)]
            res[py]["whole"].append(run_all.timed(cmd, envs[py])[0])
            res[py]["kernel_alone"].append(py_run(py, ["--kernel-child", str(patch), str(samples)],
                                                  envs[py])["kernel_alone"])
            for key, value in py_run(py, ["--loop-child", str(patch), repr(args.seconds)], envs[py]).items():
                res[py][key].append(value)
        if len(order) == 1:
            stk.append(run_all.timed(run_all.ref_command(exes, ("stk",), samples, rate, wav))[0])
        print(f"  rep {rep + 1}/{args.reps} done", file=sys.stderr, flush=True)
    return res, statistics.median(stk), samples


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] in ("--kernel-child", "--loop-child"):
        child(argv)
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="20 s renders, 3 repetitions")
    ap.add_argument("--reps", type=int, default=None)
    ap.add_argument("--python", action="append", default=None, help="an install's python (repeatable)")
    args = ap.parse_args(argv)
    args.python = args.python or [sys.executable]
    args.reps = args.reps or (3 if args.quick else 5)
    args.seconds = 20.0 if args.quick else 600.0
    with tempfile.TemporaryDirectory(prefix="hg-fig7-") as folder:
        res, stk, samples = measure(args, pathlib.Path(folder))
    print(f"Fig. 7 moving bow, {args.seconds:g} s at 19000 Hz ({samples} samples), median of {args.reps}; "
          f"STK Bowed whole run {stk:.2f} s")
    for py, r in res.items():
        m = {k: statistics.median(v) for k, v in r.items()}
        per = 1e9 / samples
        print(f"{py}:\n  whole run {m['whole']:.2f} s: {stk / m['whole']:.2f}x STK;  kernel alone "
              f"{m['kernel_alone'] * per:.1f} ns/sample ({samples / m['kernel_alone'] / 1e6:.1f} M/s)\n"
              f"  render loop {m['loop']:.2f} s = {m['loop'] * per:.1f} ns/sample: kernel {m['kernel'] * per:.1f}, "
              f"drivers (fill + send) {m['drivers'] * per:.1f} ns/sample = {100 * m['drivers'] / m['loop']:.1f} % "
              f"of the loop, {100 * m['drivers'] / m['whole']:.1f} % of the whole run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
