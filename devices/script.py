"""A simulated hand's script, sample by sample: the keyframes of a `driver: simulated` entry as
data (times, one track per axis, each segment's slope) and the @helper functions that read them.

ScriptedHaptic.output (hapticgraph.devices.simulated) with these helpers is the one definition
of what the hand does at a sample; the compiled kernel and the reference interpreter both call
it, and it gives np.interp's values bit for bit: the time t/fs (wrapped as fmod would when the
script repeats), the last keyframe at or before it, then its segment's slope·(time − keyframe) +
value, the value itself on a keyframe, the first before the script and the last after it. The
hand's velocity is its segment's slope: 0 before the first keyframe, from the last one on, and on
a segment of length zero (a jump).
"""
import math

import numpy as np

from ..blocks import helper


@helper
def script_time(t, fs, repeat, repeat_hi, repeat_lo):
    """The script's time at sample t [s]: t/fs, wrapped around the script's length when it repeats
    (`repeat` > 0) to fmod's (and np.mod's) value to the bit, without calling fmod (a call inside
    the sample loop spills every register the kernel keeps its state in).

    fmod(x, T) is x − k·T exactly, k = ⌊x/T⌋, a number a double holds. T = hi + lo split in
    halves of 26 bits (split_length), so q·hi and q·lo are exact for whole q < 2**26; with q = k,
    x − q·hi is exact too (Sterbenz for k ≥ 2; for k = 1 both are multiples of ulp(hi) and the
    difference is below 2·hi), so the one rounding left is of the exact result: none.
    q = ⌊fl(x/T)⌋ is k or k + 1 (rounding never takes x/T below the whole number k under it);
    k + 1 leaves a negative remainder (rounding keeps the sign of a non-zero difference), and one
    step back gives k. Checked against np.mod on 1.5e8 (t, fs, T): tests/devices/
    test_simulated_script.py keeps a sample of them."""
    x = t / fs
    if repeat > 0.0:
        q = math.floor(x / repeat)
        if q >= 67108864.0:               # 2**26 repeats: the products are no longer exact
            return x % repeat
        r = (x - q * repeat_hi) - q * repeat_lo
        if r < 0.0:
            q -= 1.0
            r = (x - q * repeat_hi) - q * repeat_lo
        x = r
    return x


def split_length(length):
    """(hi, lo): `length` = hi + lo exactly, each with at most 26 significant bits (Veltkamp)."""
    c = 134217729.0 * length          # 2**27 + 1
    hi = c - (c - length)
    return hi, length - hi


@helper
def script_point(x, time, value, slope, inside):
    """A track at time x, from its keyframe (time, value) at or before x and that segment's slope:
    np.interp's value to the bit (its formula and order of operations). `inside`: x lies inside
    a segment, after its keyframe; elsewhere (before the first keyframe, from the last one on,
    on a keyframe) the keyframe's value, as np.interp gives it. np.interp retries from the
    segment's end when the product is NaN; with finite keyframes (the loader refuses others)
    and x − time > 0 it never is."""
    return slope * (x - time) + value if inside else value


def track(script, times, key):
    """Key `key` of the keyframes at every keyframe's time: linear between the keyframes that
    carry it (a keyframe without it is skipped), zeros when none does."""
    keys = [(float(k["t"]), float(k[key])) for k in script if key in k]
    if not keys:
        return np.zeros(len(times))
    t, v = np.array(keys).T
    return np.interp(times, t, v)


def slopes_of(times, tracks):
    """Each segment's slope of each track (rows), as np.interp computes it; 0 for a segment of
    length zero and after the last keyframe (so a row has one slope per keyframe)."""
    dt = np.diff(times)
    out = np.zeros_like(tracks)
    np.divide(np.diff(tracks, axis=1), dt, out=out[:, :-1], where=dt > 0)
    return out


def script_data(script, axes, hold):
    """The block values of a script: `times`, `tracks` (the hand's x then each axis, one row each,
    flattened), `slopes` (the same layout) and `repeat` (the script's length when it repeats,
    0 when the last keyframe holds) with its halves `repeat_hi`, `repeat_lo` (script_time)."""
    times = np.array([float(k["t"]) for k in script])
    tracks = np.array([track(script, times, "x")] + [track(script, times, a) for a in axes])
    repeat = float(times[-1]) if not hold and times[-1] > 0 else 0.0
    hi, lo = split_length(repeat)
    return {"times": times, "tracks": tracks.ravel(), "slopes": slopes_of(times, tracks).ravel(),
            "repeat": repeat, "repeat_hi": hi, "repeat_lo": lo}


__all__ = ["script_data", "script_point", "script_time", "slopes_of", "split_length", "track"]
