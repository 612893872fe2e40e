"""Real-time benchmarks of `hapticgraph play` (results and method: benchmarks/realtime.md).

1. Headroom under a JACK dummy server (jackd2, `-d dummy`, real-time priority) at 64-frame
   blocks, 44.1 kHz: mass-spring sheets of increasing size played through the real audio path
   (sounddevice → PortAudio's JACK host API → jackd), the callback load (time in the callback /
   the 1.45 ms period: mean, 99th percentile, maximum), xruns (PortAudio status flags) and
   callbacks over their period; the largest instrument that keeps up.
2. A per-sample servo loop (blocks of ONE sample, as seed 000's 19 kHz haptic loop): the Fig. 7
   bowed string with its haptic device fed from a preallocated buffer (a recorded take, as a HID
   reader thread would hand it over), run free (the maximum rate) and paced by a deadline clock at
   20 kHz: the sustained rate, the jitter of the loop's start times and the missed deadlines.

    python benchmarks/realtime.py            # about 1.5 minutes
    python benchmarks/realtime.py --quick    # fewer sizes, shorter runs

Needs jackd (Debian jackd2) and PortAudio (libportaudio2) for part 1; part 2 needs neither.
"""
import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

SHEET = """
hapticgraph: 1
name: sheet {a}x{b}
rate: 44100
blocks:
  plate: {{type: lattice, shape: [{a}, {b}], mass: 0.001, tension: 200000.0, damping: 0.05}}
  hit: {{type: pluck, time: 0.01, force: 0.5, duration: 0.0005}}
  mic: {{type: mic, gain: 5.0, pan: 0.2}}
  out: {{type: audio_out}}
connect:
  - hit.out -> plate[{ha}, {hb}].force
  - plate[{ma}, {mb}].velocity -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""


def sheet(folder, a, b):
    path = os.path.join(folder, f"sheet_{a}x{b}.yaml")
    with open(path, "w") as f:
        f.write(SHEET.format(a=a, b=b, ha=a // 3, hb=b // 3, ma=(2 * a) // 3, mb=b // 2))
    return path


def start_jack(folder, period=64, rate=44100):
    name = f"hapticgraph-bench-{os.getpid()}"
    log = open(os.path.join(folder, "jackd.log"), "w+")
    proc = subprocess.Popen(["jackd", "-n", name, "-R", "-d", "dummy", "-r", str(rate), "-p", str(period)],
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    os.environ["JACK_DEFAULT_SERVER"] = name
    os.environ["JACK_NO_START_SERVER"] = "1"
    for _ in range(75):
        out = subprocess.run(["jack_wait", "-c", "-s", name], capture_output=True, text=True).stdout
        if "running" in out and "not" not in out:
            return proc, log
        time.sleep(0.2)
    raise RuntimeError("jackd did not start")


def stop_jack(proc):
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGTERM)
        proc.wait(10)


def headroom(sizes, seconds):
    from hapticgraph import Session, load
    from hapticgraph.devices import audio
    if shutil.which("jackd") is None:
        print("part 1 skipped: jackd (Debian jackd2) is not installed")
        return []
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        os.environ.setdefault("HAPTICGRAPH_CACHE", os.path.join(folder, "cache"))
        jack, log = start_jack(folder)
        try:
            audio.rescan()                       # PortAudio sees the server started after import
            device = audio.find_device("system", "output", 2)
            for a, b in sizes:
                patch = load(sheet(folder, a, b))
                session = Session.open(patch, blocksize=64, editable=False)   # as `play` opens it
                # the kernel alone, offline: time per 64-sample block
                for _ in range(50):
                    session.process(64)
                n = max(20, int(0.5 * 44100 / 64))
                t = time.perf_counter()
                for _ in range(n):
                    session.process(64)
                offline = (time.perf_counter() - t) / n
                session = Session.open(patch, blocksize=64, editable=False)   # as `play` opens it
                player = audio.Player(session, device=device, blocksize=64, latency="low", seconds=seconds)
                rep = player.run()
                # keeps up: no callback over its period, p99 under it, no xrun once running (an xrun
                # in the first 0.1 s, while JACK connects the ports, is counted but not held against it)
                keeps = rep.late == 0 and rep.load_p99 < 1.0 and rep.xruns == rep.xruns_startup \
                    and rep.problem is None
                rows.append({"cells": a * b, "shape": f"{a}×{b}", "offline_ms": 1e3 * offline,
                             "offline_load": offline / (64 / 44100), "mean": rep.load_mean, "p99": rep.load_p99,
                             "max": rep.load_max, "xruns": rep.xruns, "startup": rep.xruns_startup, "late": rep.late,
                             "callbacks": rep.callbacks, "wall": rep.wall, "played": rep.seconds,
                             "keeps": keeps, "problem": rep.problem})
                r = rows[-1]
                print(f"  {r['shape']:>9} {r['cells']:>7} cells: offline {r['offline_ms']:.3f} ms/block "
                      f"({100 * r['offline_load']:.1f}%); live load mean {100 * r['mean']:.1f}% p99 "
                      f"{100 * r['p99']:.1f}% max {100 * r['max']:.1f}%, xruns {r['xruns']} ({r['startup']} at start), late {r['late']}/"
                      f"{r['callbacks']}, {r['played']:.2f} s in {r['wall']:.2f} s -> "
                      f"{'keeps up' if keeps else 'does NOT keep up'}", flush=True)
                if not keeps and r["offline_load"] > 1.5:
                    break
        finally:
            try:
                import sounddevice as sd
                sd._terminate()                  # PortAudio lets go of the server before it stops
            except Exception:  # noqa: BLE001
                pass
            stop_jack(jack)
            log.close()
    return rows


def servo(seconds, rate_goal=20000.0):
    """The Fig. 7 patch stepped one sample per call, its device fed from a recorded take."""
    from hapticgraph import load
    from hapticgraph.devices import open_drivers
    from hapticgraph.devices.record import Recorder, replay_drivers
    from hapticgraph.graph.engine import Runner
    path = os.path.join(ROOT, "patches", "fig7_bowed_string.yaml")
    patch = load(path)
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        # a take of the simulated hand (what a HID reader thread would have buffered)
        s = Runner(patch, drivers=open_drivers(patch), blocksize=4096)
        rec = Recorder(os.path.join(folder, "hand"), s.prog, 2, 4096, ring_seconds=12)
        total = int(patch.rate * (2 * seconds + 2))
        for t0 in range(0, total, 4096):
            n = min(4096, total - t0)
            r = s.process(n)
            rec.push_inputs(s.ext[:n], r[:, s.prog.device_records[0][1]:])
            rec.push_audio(r[:, :2].astype(np.float32))
        rec.close()
        _, drivers = replay_drivers(patch, os.path.join(folder, "hand.hgrec"))

        def session():
            ss = Runner(patch, drivers=drivers, blocksize=64, runaway=1e3)
            ss.start()
            for d in drivers.values():
                d.sent = _Sink()          # after start(), which resets it
            for _ in range(2000):
                ss.process(1)
            return ss

        # free-running: the maximum rate
        ss = session()
        n = int(seconds * 40000)
        t = time.perf_counter()
        for _ in range(n):
            ss.process(1)
        out["free_rate"] = n / (time.perf_counter() - t)
        out["paced"] = []
        for mode in ("spin", "fifo"):
            if mode == "fifo":
                try:
                    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(50))
                except (AttributeError, PermissionError, OSError):
                    continue
            out["paced"].append(paced(session(), 1.0 / rate_goal, int(seconds * rate_goal), mode))
            if mode == "fifo":
                os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    return out


def paced(ss, period, n, mode):
    """Step `ss` one sample at every deadline t0 + k·period. `spin`: busy-wait (normal
    scheduling); `fifo`: SCHED_FIFO, sleeping all but the last 10 µs of each wait (a SCHED_FIFO
    task that only spins is throttled by the kernel's RT limit: 50 ms in every second)."""
    starts = np.zeros(n)
    clock, sleep = time.perf_counter, time.sleep
    t0 = clock() + 0.01
    for k in range(n):
        due = t0 + k * period
        if mode == "fifo":
            rest = due - clock()
            if rest > 15e-6:
                sleep(rest - 10e-6)
        while clock() < due:
            pass
        starts[k] = clock()
        ss.process(1)
    end = clock()
    late = starts - (t0 + np.arange(n) * period)
    intervals = np.diff(starts)
    return {"mode": {"spin": "busy-wait, SCHED_OTHER", "fifo": "sleep + 10 µs spin, SCHED_FIFO 50"}[mode],
            "goal": 1.0 / period, "rate": n / (end - t0), "n": n,
            "late_mean_us": 1e6 * late.mean(), "late_p99_us": 1e6 * np.percentile(late, 99),
            "late_max_us": 1e6 * late.max(), "jitter_std_us": 1e6 * intervals.std(),
            "interval_p99_us": 1e6 * np.percentile(intervals, 99), "interval_max_us": 1e6 * intervals.max(),
            "missed": int(np.sum(late > period))}


class _Sink(list):
    """Forces sent to the replayed device are dropped (a device would take them)."""

    def append(self, x):
        pass


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--seconds", type=float, default=None, help="length of each live run")
    ap.add_argument("--sheet", action="append", default=[], metavar="AxB",
                    help="play only these sheets (repeatable), e.g. --sheet 100x100")
    ap.add_argument("--runs", type=int, default=1, help="play each sheet this many times (a soak: "
                    "--sheet 100x100 --runs 5 --seconds 60); part 2 is skipped when --sheet is given")
    args = ap.parse_args(argv)
    sizes = [(10, 10), (32, 32), (71, 71), (100, 100), (141, 141), (173, 173), (224, 224), (316, 316)]
    if args.quick:
        sizes = [(10, 10), (100, 100), (316, 316)]
    if args.sheet:
        sizes = [tuple(int(x) for x in s.lower().split("x")) for s in args.sheet]
    sizes = [size for size in sizes for _ in range(max(1, args.runs))]
    seconds = args.seconds or (2.0 if args.quick else 4.0)
    print(f"part 1: sheets under jackd -d dummy, 64-frame blocks at 44.1 kHz, {seconds:g} s each")
    rows = headroom(sizes, seconds)
    if rows:
        print("\n| cells | sheet | kernel alone (ms / 64 frames) | live load mean | p99 | max | xruns (at start) | "
              "callbacks over period | keeps up |")
        print("|---:|---|---:|---:|---:|---:|---:|---:|---|")
        for r in rows:
            print(f"| {r['cells']:,} | {r['shape']} | {r['offline_ms']:.3f} ({100 * r['offline_load']:.0f}%) | "
                  f"{100 * r['mean']:.1f}% | {100 * r['p99']:.1f}% | {100 * r['max']:.1f}% | {r['xruns']} ({r['startup']}) | "
                  f"{r['late']} / {r['callbacks']} | {'yes' if r['keeps'] else 'no'} |")
        ok = [r for r in rows if r["keeps"]]
        if ok:
            print(f"\nlargest that keeps up: {ok[-1]['cells']:,} cells ({ok[-1]['shape']})")
    if args.sheet:
        return 0
    print("\npart 2: per-sample servo loop (fig7_bowed_string.yaml, blocks of 1 sample, device from a buffer)")
    s = servo(1.0 if args.quick else 5.0)
    print(f"  free-running: {s['free_rate']:,.0f} samples/s ({1e6 / s['free_rate']:.1f} µs per sample)")
    print("\n| pacing at 20 kHz | sustained rate | start lateness mean / p99 / max (µs) | interval std / p99 / max (µs) "
          "| deadlines missed by > 1 period |")
    print("|---|---:|---:|---:|---:|")
    for p in s["paced"]:
        print(f"| {p['mode']} | {p['rate']:,.0f} Hz | {p['late_mean_us']:.1f} / {p['late_p99_us']:.1f} / "
              f"{p['late_max_us']:.0f} | {p['jitter_std_us']:.1f} / {p['interval_p99_us']:.1f} / "
              f"{p['interval_max_us']:.0f} | {p['missed']} of {p['n']:,} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
