"""A simulated hand's script, sample by sample: the keyframes of a `driver: simulated` entry as
data (times, one track per axis, each segment's slope) and the @helper functions that read them.

The helpers are the one definition of what the hand does at a sample; the compiled kernel and
the reference interpreter both call them (through hapticgraph.devices.simulated.ScriptedHaptic),
and they give np.interp's values bit for bit: the time t/fs (wrapped with fmod when the script
repeats), the last keyframe at or before it, then its segment's slope·(time − keyframe) + value,
the value itself on a keyframe, the first before the script and the last after it. A hand's
velocity is its segment's slope: 0 before the first keyframe, from the last one on, and on a
segment of length zero (a jump).
"""
import math

import numpy as np

from ..blocks import helper


@helper
def script_time(t, fs, repeat):
    """The script's time at sample t [s]: t/fs, wrapped around the script's length when it repeats
    (`repeat` > 0). Float `%` is exact (fmod, then the sign of the divisor: Python, numba and
    np.mod agree), so the wrapped time is np.mod's to the bit."""
    x = t / fs
    if repeat > 0.0:
        x = x % repeat
    return x


@helper
def script_segment(x, times, guess):
    """The last keyframe at or before time x (−1 before the first), searched on from `guess`
    (the previous sample's: a step or two a sample; from the start when time went back)."""
    n = len(times)
    j = int(guess)
    if j >= n or (j >= 0 and times[j] > x):
        j = -1
    while j + 1 < n and times[j + 1] <= x:
        j += 1
    return j


@helper
def script_value(x, j, times, tracks, slopes, row):
    """Track `row` at time x in segment j: np.interp(x, times, tracks[row]) to the last bit
    (its formula, its order of operations and its fall-back when the product is NaN)."""
    n = len(times)
    at = row * n
    if j < 0:
        return tracks[at]
    if j >= n - 1:
        return tracks[at + n - 1]
    if times[j] == x:
        return tracks[at + j]
    y = slopes[at + j] * (x - times[j]) + tracks[at + j]
    if math.isnan(y):
        y = slopes[at + j] * (x - times[j + 1]) + tracks[at + j + 1]
        if math.isnan(y) and tracks[at + j] == tracks[at + j + 1]:
            y = tracks[at + j]
    return y


@helper
def script_slope(j, slopes):
    """The hand's velocity in segment j: its slope (row 0 of `slopes`); 0 before the script."""
    return slopes[j] if j >= 0 else 0.0


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
    0 when the last keyframe holds)."""
    times = np.array([float(k["t"]) for k in script])
    tracks = np.array([track(script, times, "x")] + [track(script, times, a) for a in axes])
    repeat = float(times[-1]) if not hold and times[-1] > 0 else 0.0
    return {"times": times, "tracks": tracks.ravel(), "slopes": slopes_of(times, tracks).ravel(),
            "repeat": repeat}


__all__ = ["script_data", "script_segment", "script_slope", "script_time", "script_value", "slopes_of", "track"]
