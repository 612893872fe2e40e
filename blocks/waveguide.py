"""Waveguide building blocks: delay lines and loop filters."""
import math

from .vocabulary import Block, Buffer, In, Out, Param, State


class Delay(Block, name="delay"):
    """out[n] = in[n − L]; fractional L by linear interpolation or a first-order Thiran allpass.  Ref: STK DelayL/DelayA."""

    x = In(name="in")
    y = Out(name="out")
    length = Param(1.0, unit="samples", minimum=1.0, maximum=float(1 << 24), live=False,
                   doc="delay L in samples; a fractional part interpolates")
    interpolation = Param("linear", choices=("linear", "allpass"),
                          doc="linear: (1−f)·in[n−N] + f·in[n−N−1]; allpass: Thiran, flat magnitude")
    line = Buffer(lambda p, fs: int(math.ceil(p.length)) + 2)
    y1 = State(0.0)
    structure = ("whole",)     # a whole-number length folds the interpolation away; n, c0, c1, a are data

    @classmethod
    def check(cls, p, fs):
        if p.interpolation == "allpass" and p.length < 1.5:
            yield "length", "an allpass delay needs length ≥ 1.5 samples (its fractional part lies in [0.5, 1.5))"

    @staticmethod
    def derive(p, fs):
        if p.interpolation == "allpass":
            # N + Δ with Δ in [0.5, 1.5): the Thiran coefficient stays in (−1/3, 1/3], far from the unit circle
            n = int(math.floor(p.length - 0.5))
            d = p.length - n
            a = (1.0 - d) / (1.0 + d)
            return {"n": n, "c0": a, "c1": 1.0, "a": a, "whole": False}
        n = int(math.floor(p.length))
        f = p.length - n
        return {"n": n, "c0": 1.0 - f, "c1": f, "a": 0.0, "whole": f == 0.0}

    @staticmethod
    def output(line, line_mask, t, n, c0, c1, a, y1, whole):
        if whole:
            # a whole-number length: `whole` is structure (declared), so this branch folds away
            # at compile time (strict IEEE arithmetic could not drop the `0.0 * x` terms by
            # itself); the length itself is data, and c0 is then exactly 1.0 (1.0·x is x)
            return line[(t - n) & line_mask]
        return c0 * line[(t - n) & line_mask] + c1 * line[(t - n - 1) & line_mask] - a * y1

    @staticmethod
    def update(line, line_mask, t, x, y):
        line[t & line_mask] = x
        return y


class Lowpass(Block, name="lowpass"):
    """out[n] = gain · Σᵢ coeffs[i] · in[n − i] (FIR; the default taps are linear phase, 1 sample of group delay).  Ref: Berdahl et al. 2009 Fig. 4 H_lp."""

    x = In(name="in")
    y = Out(name="out")
    coeffs = Param([0.25, 0.5, 0.25], minimum=-1e3, maximum=1e3, min_items=1, max_items=256,
                   doc="FIR taps, newest sample first")
    gain = Param(1.0, minimum=-10.0, maximum=10.0, doc="loop gain, negative for an inverting reflection")
    hist = Buffer(lambda p, fs: len(p.coeffs))

    @staticmethod
    def output(x, hist, hist_mask, t, coeffs, gain):
        acc = coeffs[0] * x
        for i in range(1, len(coeffs)):
            acc += coeffs[i] * hist[(t - i) & hist_mask]
        return gain * acc

    @staticmethod
    def update(hist, hist_mask, t, x):
        hist[t & hist_mask] = x


class VariableDelay(Block, name="vdelay"):
    """out[n] = (1 − f)·in[n − N] + f·in[n − N − 1], N + f = L[n] clamped to [1, max_length]; L = fs/frequency − loop when frequency > 0, else length.  Ref: Faust de.fdelay, STK DelayL."""

    x = In(name="in")
    y = Out(name="out")
    length = Param(100.0, unit="samples", minimum=1.0, maximum=float(1 << 20),
                   doc="the delay while `frequency` is 0; a fractional part interpolates")
    frequency = Param(0.0, unit="Hz", minimum=0.0, maximum=1e5,
                      doc="when > 0 the delay is fs/frequency − loop: a feedback loop through it is tuned to this pitch")
    loop = Param(0.0, unit="samples", minimum=0.0, maximum=1e3, live=False,
                 doc="the delay the rest of the loop adds (a 3-tap lowpass: 1), subtracted when tuning")
    max_length = Param(4096, minimum=2, maximum=1 << 20, doc="the longest delay; longer ones are clamped to it")
    line = Buffer(lambda p, fs: int(p.max_length) + 2)

    @staticmethod
    def derive(p, fs):
        return {"cap": float(p.max_length)}

    @staticmethod
    def output(line, line_mask, t, length, frequency, fs, loop, cap):
        d = fs / frequency - loop if frequency > 0.0 else length
        d = min(max(d, 1.0), cap)
        n = int(d)
        f = d - n
        return (1.0 - f) * line[(t - n) & line_mask] + f * line[(t - n - 1) & line_mask]

    @staticmethod
    def update(line, line_mask, t, x):
        line[t & line_mask] = x
