#!/usr/bin/env python
"""Fig. 7's kernel against the same computation written by hand as one bare numba loop, and
against the loop-carried chain that bounds both: where the limit of the bowed string lies.

    python benchmarks/bowed_bare.py [--samples 4000000] [--reps 7]

Rows, timed in turn each repetition (median of --reps, ns a sample; the same sample count for
every row, so the rates compare the work of one sample):
- kernel, 19 kHz: `CompiledKernel.run` of patches/fig7_bowed_string.yaml with its hand's script
  repeated (run_all.fig7_patch), one call over every sample into a prefaulted recording;
- kernel, 44.1 kHz: the same patch at `rate: 44100` (the same 100-sample string: 441 Hz; what
  bowed_vs_stk.py and fig7_row.py --rate 44100 run);
- kernel, 44.1 kHz tuned: the string's delays scaled by 44100/19000 (23 + 88 + 90 + 23: 190 Hz as
  at 19 kHz), so its ring buffers are 32 and 128 samples long instead of 16 and 64;
- kernel, 44.1 kHz, string + bow: bowed_vs_stk.patch_for(device=False), the haptic device replaced
  by a constant bow velocity (what the device's integration adds to a sample);
- bare loop: the 44.1 kHz kernel's computation by hand, every block inlined, state in locals,
  delay lengths and ring masks as literals, the same records and the same guard test; its
  records are checked equal to the kernel's, bit for bit, before anything is timed;
- bow chain: only what one sample needs from the previous one through the bow (the junction's
  v from the last force, the friction curve, the device's velocity pulled by −force), with the
  string's incoming waves and the hand's position read from arrays computed beforehand (its
  velocity a constant 0.2 m/s);
- sqrt + div floor: x = d/sqrt(d² + ε²) with d = b − g·x, the square root and the division in
  series on the loop, nothing else;
- STK `Bowed` (ref_bowed.cpp, g++ -O3 -march=native), its tick loop timed inside it, at 19 kHz
  and 44.1 kHz: the reference the bowed row's ratio is taken against.
"""
import argparse
import math
import os
import pathlib
import platform
import statistics
import sys
import tempfile
import time

import numba
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import benchlib  # noqa: E402
import bowed_vs_stk  # noqa: E402
import run_all  # noqa: E402

from hapticgraph import load  # noqa: E402
from hapticgraph.devices import open_drivers  # noqa: E402
from hapticgraph.devices.script import script_data  # noqa: E402
from hapticgraph.graph.kernel import CompiledKernel  # noqa: E402
from hapticgraph.graph.program import Program  # noqa: E402

TUNED = {"r1": 23, "r2": 88, "l1": 90, "l2": 23}      # 19000 Hz's 10 + 38 + 39 + 10, scaled to 44.1 kHz


def patch_at(folder, rate, tuned=False):
    """run_all.fig7_patch (the hand's script repeated) at `rate`; `tuned`: delays scaled to 190 Hz."""
    text = run_all.fig7_patch(folder).read_text(encoding="utf-8")
    edits = [("rate: 19000\n", f"rate: {rate}\n")]
    if tuned:
        edits += [(f"  {name}:{' ' * (7 - len(name))}{{type: delay, length: {old}}}",
                   f"  {name}:{' ' * (7 - len(name))}{{type: delay, length: {TUNED[name]}}}")
                  for name, old in (("r1", 10), ("r2", 38), ("l1", 39), ("l2", 10))]
    for old, new in edits:
        if old not in text:
            sys.exit(f"bowed_bare: patches/fig7_bowed_string.yaml changed ({old.strip()!r}); update patch_at()")
        text = text.replace(old, new)
    path = pathlib.Path(folder) / f"fig7_{rate}{'_tuned' if tuned else ''}.yaml"
    path.write_text(text, encoding="utf-8")
    return path


class Kernel:
    """A patch's compiled kernel, run from its initial state over n samples (the hand in the kernel)."""

    def __init__(self, path, samples):
        self.patch = load(str(path))
        self.samples = samples
        self.rec = None

    def once(self):
        prog = Program(self.patch, (), open_drivers(self.patch))
        ck = CompiledKernel(prog)
        rec = np.empty((self.samples, len(prog.records)))
        rec.fill(0.0)
        ext = np.zeros((self.samples, len(prog.ext_columns)))
        start = time.perf_counter()
        code = ck.run(0, rec, ext)
        seconds = time.perf_counter() - start
        assert code == 0, code
        assert np.all(np.isfinite(rec)) and np.any(rec[:, 0] != 0.0), "silent or not finite"
        self.rec = rec
        return seconds


# ---------------------------------------------------------------------------------------------
# the bare loops
# ---------------------------------------------------------------------------------------------
@numba.njit(nogil=True)
def fig7_bare(n, fs, times, tracks, slopes, repeat, repeat_hi, repeat_lo, rec):
    """The Fig. 7 patch at fs, as the kernel computes it (the same operations in the same order)."""
    r1 = np.zeros(16)
    r2 = np.zeros(64)
    l1 = np.zeros(64)
    l2 = np.zeros(16)
    hist = np.zeros(4)
    g = 0.5 / 0.5                                   # junction: 1/(2 R0)
    c0, c1, c2, bridge_gain = 0.1, 0.8, 0.1, -0.995
    mus, mud, v0, eps = 0.8, 0.3, 0.1, 0.07
    pressure = 0.12
    dt_over_m, dt = 1.0 / (0.05 * fs), 1.0 / fs
    k_hand, r_hand, max_force = 2000.0, 10.0, 4.0
    pole = 0.999
    theta = (0.0 + 1.0) * (0.25 * math.pi)
    cos_t, sin_t = math.cos(theta), math.sin(theta)
    limit = 1.7976931348623157e308
    a1 = b1 = f1 = 0.0
    pos, vel, segment, xs1 = -0.16, 0.0, -1.0, 0.0
    count = len(times)
    bad = False
    for t in range(n):
        r1_y = r1[(t - 10) & 15]
        h = g * f1
        bl = b1 + h
        a_r = a1 + h
        v = r1_y + bl
        r2_y = r2[(t - 38) & 63]
        bridge_y = bridge_gain * (c0 * r2_y + c1 * hist[(t - 1) & 3] + c2 * hist[(t - 2) & 3])
        l1_y = l1[(t - 39) & 63]
        l2_y = l2[(t - 10) & 15]
        nut_y = -1.0 * l2_y
        # the hand: its script's time (wrapped), keyframe and segment
        x = t / fs
        if repeat > 0.0:
            q = math.floor(x / repeat)
            r = (x - q * repeat_hi) - q * repeat_lo
            if r < 0.0:
                q -= 1.0
                r = (x - q * repeat_hi) - q * repeat_lo
            x = r
        j = int(segment)
        if j >= count or (j >= 0 and times[j] > x):
            j = -1
        while j + 1 < count and times[j + 1] <= x:
            j += 1
        kk = min(max(j, 0), count - 1)
        inside = 0 <= j < count - 1 and times[kk] != x
        hand_x = slopes[kk] * (x - times[kk]) + tracks[kk] if inside else tracks[kk]
        hand_v = slopes[kk] if j >= 0 else 0.0
        # the bow: friction curve at dv
        dv = vel - v
        w = math.sqrt(dv * dv + eps * eps)
        if w == 0.0:
            mu = 0.0
        else:
            a = abs(dv)
            mu = dv / w * (mud + (mus - mud) * v0 / (v0 + a) if v0 + a > 0.0 else mus)
        force = max(pressure, 0.0) * mu
        react = -1.0 * force
        xs = pole * xs1 + v * dt
        gm = 1.0 * bridge_y
        left, right = gm * cos_t, gm * sin_t
        rec[t, 0] = left
        rec[t, 1] = right
        rec[t, 2] = react
        bad |= not (abs(left) <= limit)
        bad |= not (abs(right) <= limit)
        bad |= not (abs(react) <= limit)
        if not bad:
            rec[t, 2] = min(max(react, -max_force), max_force)
        # updates
        r1[t & 15] = nut_y
        a1, b1, f1 = r1_y, l1_y, force
        r2[t & 63] = a_r
        hist[t & 3] = r2_y
        l1[t & 63] = bridge_y
        l2[t & 15] = bl
        fc = 0.0 if not math.isfinite(react) else min(max(react, -max_force), max_force)
        f = k_hand * (hand_x - pos) + r_hand * (hand_v - vel) + fc
        vel = vel + f * dt_over_m
        pos = pos + vel * dt
        segment = float(j)
        xs1 = xs
    return bad


@numba.njit(nogil=True)
def bow_chain(n, fs, waves, hand, out):
    """Only the chain one sample hands the next through the bow: v from the last force, the
    friction curve, the device's velocity; the string's waves and the hand's position come from
    arrays, the hand's velocity is 0.2 m/s."""
    mus, mud, v0, eps = 0.8, 0.3, 0.1, 0.07
    dt_over_m, dt = 1.0 / (0.05 * fs), 1.0 / fs
    f1, pos, vel = 0.0, -0.16, 0.0
    for t in range(n):
        v = waves[t & 1023] + 1.0 * f1
        dv = vel - v
        w = math.sqrt(dv * dv + eps * eps)
        a = abs(dv)
        force = 0.12 * (dv / w * (mud + (mus - mud) * v0 / (v0 + a)))
        out[t] = force
        f = 2000.0 * (hand[t & 1023] - pos) + 10.0 * (0.2 - vel) + min(max(-force, -4.0), 4.0)
        vel = vel + f * dt_over_m
        pos = pos + vel * dt
        f1 = force
    return vel


@numba.njit(nogil=True)
def divider_floor(n, b, g, e2):
    """x = d/sqrt(d² + ε²), d = b − g·x: one square root and one division in series a sample."""
    x = 0.0
    for _ in range(n):
        d = b - g * x
        x = d / math.sqrt(d * d + e2)
    return x


class Bare:
    def __init__(self, rate, samples):
        data = script_data([{"t": 0.0, "x": -0.16}, {"t": 1.6, "x": 0.16}, {"t": 3.2, "x": -0.16}], [], False)
        self.args = (float(rate), data["times"], data["tracks"], data["slopes"], data["repeat"],
                     data["repeat_hi"], data["repeat_lo"])
        self.samples, self.rate = samples, float(rate)
        self.rec = np.empty((samples, 3))
        self.rec.fill(0.0)
        rng = np.random.default_rng(1)
        self.waves = rng.uniform(-0.3, 0.3, 1024)
        self.hand = np.linspace(-0.16, 0.16, 1024)
        self.out = np.zeros(samples)
        fig7_bare(10, *self.args, self.rec)
        bow_chain(10, self.rate, self.waves, self.hand, self.out)
        divider_floor(10, 0.2, 1.0, 0.0049)

    def loop(self):
        start = time.perf_counter()
        bad = fig7_bare(self.samples, *self.args, self.rec)
        seconds = time.perf_counter() - start
        assert not bad
        return seconds

    def chain(self):
        start = time.perf_counter()
        bow_chain(self.samples, self.rate, self.waves, self.hand, self.out)
        return time.perf_counter() - start

    def floor(self):
        start = time.perf_counter()
        divider_floor(self.samples, 0.2, 1.0, 0.0049)
        return time.perf_counter() - start


def stk_loop(exe, samples, rate, wav):
    _, stdout = run_all.timed(run_all.ref_command({"stk": exe}, ("stk",), samples, rate, wav))
    return run_all.loop_seconds(stdout)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=4_000_000, help="samples a run (default 4,000,000)")
    ap.add_argument("--reps", type=int, default=7, help="repetitions, median counts (default 7)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hg-bowed-bare-") as folder:
        folder = pathlib.Path(folder)
        os.environ.setdefault("HAPTICGRAPH_CACHE", str(folder / "cache"))
        exes, versions = run_all.build(folder)
        wav = folder / "stk.wav"
        kernels = {"kernel, 19 kHz": Kernel(patch_at(folder, 19000), args.samples),
                   "kernel, 44.1 kHz": Kernel(patch_at(folder, 44100), args.samples),
                   "kernel, 44.1 kHz tuned (190 Hz: longer delays)": Kernel(patch_at(folder, 44100, True),
                                                                            args.samples),
                   "kernel, 44.1 kHz, string + bow (no device)": Kernel(bowed_vs_stk.patch_for(44100, folder, False),
                                                                        args.samples)}
        bare = Bare(44100, args.samples)
        for k in kernels.values():
            k.once()                                       # compile (or load) first
        bare.loop()
        same = np.array_equal(bare.rec, kernels["kernel, 44.1 kHz"].rec)
        if not same:
            diff = np.max(np.abs(bare.rec - kernels["kernel, 44.1 kHz"].rec))
            sys.exit(f"bowed_bare: the bare loop's records differ from the kernel's (max |difference| {diff:g})")
        rows = {**{name: k.once for name, k in kernels.items()},
                "bare loop, 44.1 kHz (records equal to the kernel's)": bare.loop,
                "bow chain alone": bare.chain, "sqrt + div floor": bare.floor,
                "STK Bowed loop, 19 kHz": lambda: stk_loop(exes["stk"], args.samples, 19000, wav),
                "STK Bowed loop, 44.1 kHz": lambda: stk_loop(exes["stk"], args.samples, 44100, wav)}
        times = {name: [] for name in rows}
        load_before = os.getloadavg()
        for rep in range(args.reps):
            order = list(rows) if rep % 2 == 0 else list(rows)[::-1]
            for name in order:
                times[name].append(rows[name]())
            print(f"  rep {rep + 1}/{args.reps}", file=sys.stderr, flush=True)
        load_after = os.getloadavg()
    per = 1e9 / args.samples
    med = {name: statistics.median(v) * per for name, v in times.items()}
    print(f"Fig. 7 bowed string, {args.samples} samples a run, median of {args.reps} (ns a sample; range in brackets); "
          f"{benchlib.cpu_model()}, {os.cpu_count()} CPUs; Python {platform.python_version()}, numba "
          f"{numba.__version__}, {versions[1]}; load average {load_before[0]:.2f} before, {load_after[0]:.2f} after")
    for name, v in times.items():
        lo, hi = min(v) * per, max(v) * per
        print(f"  {name:52} {med[name]:6.1f}  ({lo:.1f}-{hi:.1f})")
    for rate, label in ((19000, "19 kHz"), (44100, "44.1 kHz")):
        print(f"  STK / kernel at {label}: {med[f'STK Bowed loop, {label}'] / med[f'kernel, {label}']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
