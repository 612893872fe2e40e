#!/usr/bin/env python
"""Servo: what one `Session.process(1)` costs (one sample per call, as a haptic servo loop runs).

    python benchmarks/servo.py                # 200,000 calls a repetition, median of 5
    python benchmarks/servo.py --calls 50000 --reps 3

Three cases, interleaved (every repetition runs each case once, alternating which goes first):

- *string, no device*: `benchmarks/waveguide_string.yaml` (a plucked waveguide string; no driver);
- *Fig. 7, simulated device*: `patches/fig7_bowed_string.yaml` with its simulated device (the
  driver's `fill` and `send` every call, as `hapticgraph run` drives it);
- *Fig. 7, buffered device*: the same patch and device model (the same kernel), its driver a
  minimal one defined here the way a HID reader hands over its buffer: `fill` copies the hand's
  trajectory (the simulated device's, computed beforehand) from a preallocated array, `send`
  keeps the last force. This is the framework's own cost of a device patch.

Each figure is µs per call, the median over the repetitions of (time of `calls` calls / calls),
twice from the same runs: by the wall clock (what a servo loop sees, preemption by other processes
included) and by the thread's CPU time (`time.thread_time`: the call's own cost, steadier on a
shared machine). Then the breakdown, timed the same way on the same sessions: the kernel call
alone (`CompiledKernel.run` on the session's views: the guard folded in, the entry point), the
same through numba's dispatcher (what the fast call saves), and each driver's `fill` and `send`.
"""
import argparse
import os
import pathlib
import platform
import statistics
import sys
import time

import numpy as np
import benchlib

HERE = pathlib.Path(__file__).resolve().parent
FIG7 = HERE.parent / "patches" / "fig7_bowed_string.yaml"
CASES = [("string, no device", HERE / "waveguide_string.yaml", False),
         ("Fig. 7, simulated device", FIG7, False),
         ("Fig. 7, buffered device", FIG7, True)]
GOAL = 3.0      # µs per call (issue 13)


def machine():
    cpu = benchlib.cpu_model()
    import numba
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{cpu}, {os.cpu_count()} CPUs, load average {load:.2f}; Python {platform.python_version()}, "
            f"numba {numba.__version__}, numpy {np.__version__}")


def buffered(drivers, rate, samples=1 << 16):
    """Drivers like `drivers` whose inputs come from a buffer filled beforehand (see the doc)."""
    from hapticgraph.graph.engine import Driver

    class Buffered(Driver):
        def __init__(self, model):
            self.name, self.columns, self.block_type = model.name, model.columns, model.block_type
            self.values, self.max_force = model.block_values(), model.max_force
            model.start(rate)
            self.track = np.zeros((samples, len(self.columns)))
            model.fill(0, self.track)
            self.last = 0.0

        def block_values(self):
            return dict(self.values)

        def fill(self, t0, ext):
            k = t0 % (samples - ext.shape[0])
            ext[:] = self.track[k:k + ext.shape[0]]

        def send(self, t0, force):
            self.last = force[-1]
    return {name: Buffered(d) for name, d in drivers.items()}


def session(path, buffer=False):
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.engine import Runner
    patch = load(str(path))
    drivers = open_drivers(patch)
    if buffer:
        drivers = buffered(drivers, float(patch.rate))
    s = Runner(patch, drivers=drivers, blocksize=64, runaway=1e3)
    for _ in range(2000):                      # warm: the views made, the entry point remembered
        s.process(1)
    return s


def per_call(fn, calls):
    """(wall, CPU) µs per call of fn() over `calls` calls."""
    wall, cpu = time.perf_counter(), time.thread_time()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - wall) / calls * 1e6, (time.thread_time() - cpu) / calls * 1e6


def parts(s):
    """name -> a callable doing one part of process(1) on session s's own views."""
    _, rec, ext, fills, sends = s.views
    k, p = s.engine, s.prog
    out = {"process(1)": lambda: s.process(1),
           "kernel (CompiledKernel.run)": lambda: k.run(s.t, rec, ext),
           "kernel through the dispatcher": lambda: k.fn(1, s.t, p.state, p.live, p.coef, rec, ext, *k.extra)}
    for driver, columns in fills:
        out[f"{driver.name}: fill"] = lambda d=driver, c=columns: d.fill(s.t, c)
    for driver, force, _ in sends:
        out[f"{driver.name}: send"] = lambda d=driver, f=force: d.send(s.t, f)
    return out


def _stats(v):
    return f"  {statistics.median(v):7.3f} [{min(v):.3f} … {max(v):.3f}]"


def restart(s):
    """Drivers restarted between repetitions (the simulated device keeps what it was sent)."""
    s.stop()
    s.start()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=200_000, help="calls a repetition (default 200,000)")
    ap.add_argument("--reps", type=int, default=5, help="repetitions, interleaved (default 5)")
    args = ap.parse_args(argv)
    print(f"$ python benchmarks/servo.py --calls {args.calls} --reps {args.reps}")
    print(f"machine: {machine()}")
    sessions = [(label, session(path, buffer)) for label, path, buffer in CASES]
    times = {(label, name): [] for label, s in sessions for name in parts(s)}
    where = {label: os.path.relpath(path, HERE.parent) for label, path, _ in CASES}
    for rep in range(args.reps):
        order = sessions if rep % 2 == 0 else sessions[::-1]    # alternate which goes first
        for label, s in order:
            for name, fn in parts(s).items():
                restart(s)
                times[(label, name)].append(per_call(fn, args.calls))
    print(f"\nµs per call, median of {args.reps} interleaved repetitions of {args.calls:,} calls "
          "[min … max]; wall clock, then the thread's CPU time:")
    for label, s in sessions:
        print(f"\n{label} ({where[label]}):")
        for name in parts(s):
            print(f"  {name:31s}" + "".join(_stats([v[j] for v in times[(label, name)]]) for j in (0, 1)))
        wall, cpu = (statistics.median(v[j] for v in times[(label, "process(1)")]) for j in (0, 1))
        print(f"  goal process(1) ≤ {GOAL:g} µs: wall {'met' if wall <= GOAL else 'NOT met'}, "
              f"CPU {'met' if cpu <= GOAL else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
