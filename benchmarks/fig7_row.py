#!/usr/bin/env python
"""The Fig. 7 row of run_all.py alone, at one or more rates, and where its whole run's time goes;
optionally for several installs of hapticgraph at once, interleaved (before and after a change).

    python benchmarks/fig7_row.py                      # 600 s at 19 kHz, median of 5
    python benchmarks/fig7_row.py --rate 19000 --rate 44100   # both rates, interleaved
    python benchmarks/fig7_row.py --quick              # 20 s, median of 3
    python benchmarks/fig7_row.py --python A/bin/python --python B/bin/python   # compare installs

Per repetition, rate and install, in turn (the installs alternate which goes first, STK between;
the long and short runs alternate their order from one repetition to the next):
- whole run: `hapticgraph run PATCH --seconds S --out X.wav` in a fresh process, kernel cache warm
  (run_all.py's headline figure), against STK's Bowed (ref_bowed.cpp), process start to exit;
- marginal (the goal's measure): the whole run minus a 0.5 s whole run, on each side;
- kernel alone: one CompiledKernel.run over the whole render (run_all.kernel_run), against STK's
  tick loop timed inside ref_bowed;
- render loop: engine.stream into a sink that keeps nothing, with the time spent in the kernel
  (runner.run) and in the drivers (fill + send) summed apart: the drivers' share of the loop;
- with the WAV: engine.stream into the FileSink `hapticgraph run` uses, wall and CPU time of the
  process (every thread), and the CPU time of its writer thread in AudioWriter.write (float32
  conversion, peak, libsndfile's write into the page cache): what the second core takes off the
  kernel's when it is free, and adds to it when other work holds it.
The patch is run_all.fig7_patch's: patches/fig7_bowed_string.yaml with the hand's script
repeated (hold: false), so the simulated device keeps moving the bow, at `rate: R` for --rate R
(the same 100-sample string: 190 Hz at 19 kHz, 441 Hz at 44.1 kHz; STK plays rate/100 Hz).
"""
import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import benchlib  # noqa: E402
import run_all  # noqa: E402

SHORT_SECONDS = run_all.SHORT_SECONDS


def patch_at(folder, rate):
    """run_all.fig7_patch at `rate` (its own file: fig7_bowed_string_moving_RATE.yaml)."""
    path = run_all.fig7_patch(folder)
    text = path.read_text(encoding="utf-8")
    if "rate: 19000\n" not in text:
        sys.exit("fig7_row: patches/fig7_bowed_string.yaml changed; update patch_at()")
    out = path.with_name(f"{path.stem}_{rate}.yaml")
    out.write_text(text.replace("rate: 19000\n", f"rate: {rate}\n"), encoding="utf-8")
    return out


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


def sink_child(patch, seconds, wav):
    """Time one engine.stream of the patch into hapticgraph run's FileSink: wall and process CPU
    seconds (every thread), the kernel's seconds and the writer thread's CPU seconds."""
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.devices.files import FileSink
    from hapticgraph.graph import engine

    patch = load(str(patch))
    spent = {"kernel": 0.0, "writer_cpu": 0.0}
    make = engine.make_engine

    def runner(prog, which="compiled"):
        r = make(prog, which)
        run = r.run

        def timed(*args):
            start = time.perf_counter()
            code = run(*args)
            spent["kernel"] += time.perf_counter() - start
            return code
        r.run = timed
        return r
    engine.make_engine = runner
    sink = FileSink(wav, None, patch.rate, 2, [])        # the patch's audio_out: left, right
    write = sink.audio.write

    def timed_write(block):
        start = time.thread_time()
        write(block)
        spent["writer_cpu"] += time.thread_time() - start
    sink.audio.write = timed_write
    wall, cpu = time.perf_counter(), time.process_time()
    engine.stream(patch, seconds, sink, drivers=open_drivers(patch))
    sink.close()
    return {"sink_wall": time.perf_counter() - wall, "sink_cpu": time.process_time() - cpu,
            "sink_kernel": spent["kernel"], "writer_cpu": spent["writer_cpu"]}


def child(argv):
    what, patch, amount = argv[0], argv[1], float(argv[2])
    if what == "--kernel-child":
        seconds, audio = run_all.kernel_run(patch, int(amount))
        assert audio.any()
        print(json.dumps({"kernel_alone": seconds}))
    elif what == "--sink-child":
        print(json.dumps(sink_child(patch, amount, argv[3])))
    else:
        print(json.dumps(loop_child(patch, amount)))


def timed(cmd, env=None):
    """run_all.timed (wall seconds, standard output), and the child's CPU seconds (user + system,
    every thread): on a shared machine the wall time holds other work's share too."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    seconds, stdout = run_all.timed(cmd, env)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return seconds, stdout, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def py_run(python, args, env):
    proc = subprocess.run([python, str(pathlib.Path(__file__).resolve()), *args], check=True,
                          capture_output=True, text=True, env=env)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def hg_exe(python):
    exe = pathlib.Path(python).with_name("hapticgraph")
    return [str(exe)] if exe.exists() else [python, "-m", "hapticgraph"]


def measure(args, folder):
    exes, _ = run_all.build(folder)
    patches = {rate: patch_at(folder, rate) for rate in args.rate}
    envs = {}
    for k, py in enumerate(args.python):
        envs[py] = benchlib.child_env(HAPTICGRAPH_CACHE=str(folder / f"cache{k}"))
        for patch in patches.values():
            run_all.timed(hg_exe(py) + ["run", str(patch), "--seconds", "0.1", "--out", str(folder / "w.wav")],
                          envs[py])
    keys = ("whole", "short", "whole_cpu", "short_cpu", "kernel_alone", "loop", "kernel", "drivers", "sink_wall",
            "sink_cpu", "sink_kernel", "writer_cpu")
    res = {(rate, py): {k: [] for k in keys} for rate in args.rate for py in args.python}
    stk = {rate: {"whole": [], "short": [], "whole_cpu": [], "short_cpu": [], "loop": [], "rep": []}
           for rate in args.rate}
    wav = folder / "out.wav"

    def stk_runs(rate, rep):
        samples = round(args.seconds * rate)
        pair = [("whole", samples), ("short", round(SHORT_SECONDS * rate))]
        for key, n in (pair if rep % 2 == 0 else pair[::-1]):
            seconds, stdout, cpu = timed(run_all.ref_command(exes, ("stk",), n, rate, wav))
            stk[rate][key].append(seconds)
            stk[rate][key + "_cpu"].append(cpu)
            if key == "whole":
                stk[rate]["rep"].append(rep)
                stk[rate]["loop"].append(run_all.loop_seconds(stdout))

    load_before = os.getloadavg()
    for rep in range(args.reps):
        for rate in (args.rate if rep % 2 == 0 else args.rate[::-1]):
            patch, samples = patches[rate], round(args.seconds * rate)
            order = args.python if rep % 2 == 0 else args.python[::-1]
            for k, py in enumerate(order):
                if k == len(order) // 2:
                    stk_runs(rate, rep)
                r = res[(rate, py)]
                pair = [("whole", args.seconds), ("short", SHORT_SECONDS)]
                for key, length in (pair if rep % 2 == 0 else pair[::-1]):
                    cmd = hg_exe(py) + ["run", str(patch), "--seconds", repr(length), "--out", str(wav)]
                    seconds, _, cpu = timed(cmd, envs[py])
                    r[key].append(seconds)
                    r[key + "_cpu"].append(cpu)
                r["kernel_alone"].append(py_run(py, ["--kernel-child", str(patch), str(samples)],
                                                envs[py])["kernel_alone"])
                for child_args in (["--loop-child", str(patch), repr(args.seconds)],
                                   ["--sink-child", str(patch), repr(args.seconds), str(folder / "sink.wav")]):
                    for key, value in py_run(py, child_args, envs[py]).items():
                        r[key].append(value)
            if len(order) == 1:
                stk_runs(rate, rep)
        print(f"  rep {rep + 1}/{args.reps} done (load average {os.getloadavg()[0]:.2f})", file=sys.stderr,
              flush=True)
    return res, stk, (load_before, os.getloadavg())


def report(args, rate, res, stk):
    samples = round(args.seconds * rate)
    per = 1e9 / samples                                   # seconds of the whole render -> ns a sample
    s = {k: statistics.median(v) for k, v in stk.items() if k != "rep"}
    stk_marginal, stk_cpu = s["whole"] - s["short"], s["whole_cpu"] - s["short_cpu"]
    stk_each = [statistics.median(w - sh for w, sh, r in zip(stk["whole"], stk["short"], stk["rep"]) if r == rep)
                for rep in range(args.reps)]              # STK's marginal in each repetition
    print(f"{rate} Hz ({samples} samples): STK Bowed whole run {s['whole']:.2f} s, marginal {stk_marginal:.2f} s "
          f"= {stk_marginal * per:.1f} ns/sample ({stk_cpu * per:.1f} CPU), tick loop {s['loop'] * per:.1f} ns/sample")
    for py in args.python:
        r = res[(rate, py)]
        m = {k: statistics.median(v) for k, v in r.items()}
        marginal, cpu = m["whole"] - m["short"], m["whole_cpu"] - m["short_cpu"]
        each = ", ".join(f"{sm / (hw - hs):.2f}" for sm, hw, hs in zip(stk_each, r["whole"], r["short"]))
        print(f"  {py}:")
        print(f"    whole run {m['whole']:.2f} s: {s['whole'] / m['whole']:.2f}x STK;  marginal {marginal:.2f} s "
              f"= {marginal * per:.1f} ns/sample: {stk_marginal / marginal:.2f}x STK (each repetition: {each}); "
              f"CPU (user + system, every thread) {cpu * per:.1f} ns/sample: {stk_cpu / cpu:.2f}x STK's")
        print(f"    kernel alone {m['kernel_alone'] * per:.1f} ns/sample "
              f"({samples / m['kernel_alone'] / 1e6:.1f} M/s): {s['loop'] / m['kernel_alone']:.2f}x STK's tick loop")
        print(f"    render loop {m['loop']:.2f} s = {m['loop'] * per:.1f} ns/sample: kernel {m['kernel'] * per:.1f}, "
              f"drivers (fill + send) {m['drivers'] * per:.1f} ns/sample = {100 * m['drivers'] / m['loop']:.1f} % "
              f"of the loop, {100 * m['drivers'] / m['whole']:.1f} % of the whole run")
        print(f"    with the WAV: {m['sink_wall'] * per:.1f} ns/sample wall, {m['sink_cpu'] * per:.1f} CPU (every "
              f"thread): kernel {m['sink_kernel'] * per:.1f}, writer thread {m['writer_cpu'] * per:.1f}", flush=True)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] in ("--kernel-child", "--loop-child", "--sink-child"):
        child(argv)
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="20 s renders, 3 repetitions")
    ap.add_argument("--reps", type=int, default=None)
    ap.add_argument("--seconds", type=float, default=None, help="render length (default 600, --quick 20)")
    ap.add_argument("--rate", type=int, action="append", default=None,
                    help="the patch's rate, Hz (repeatable; default 19000, the patch's own)")
    ap.add_argument("--python", action="append", default=None, help="an install's python (repeatable)")
    args = ap.parse_args(argv)
    args.python = args.python or [sys.executable]
    args.rate = args.rate or [19000]
    args.reps = args.reps or (3 if args.quick else 5)
    args.seconds = args.seconds or (20.0 if args.quick else 600.0)
    with tempfile.TemporaryDirectory(prefix="hg-fig7-") as folder:
        res, stk, (before, after) = measure(args, pathlib.Path(folder))
    print(f"Fig. 7 moving bow, {args.seconds:g} s, median of {args.reps}; {benchlib.cpu_model()}, "
          f"load average {before[0]:.2f} before, {after[0]:.2f} after")
    for rate in args.rate:
        report(args, rate, res, stk[rate])
    return 0


if __name__ == "__main__":
    sys.exit(main())
