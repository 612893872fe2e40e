"""Control and utility blocks: constants, gains, sums, range mapping, sample-and-hold, envelope."""
import math

from .vocabulary import Block, In, Out, Param, State


class Constant(Block, name="constant"):
    """out[n] = value."""

    y = Out(name="out")
    value = Param(0.0, minimum=-1e12, maximum=1e12)

    @staticmethod
    def output(value):
        return value


class Gain(Block, name="gain"):
    """out[n] = gain · in[n]."""

    x = In(name="in")
    y = Out(name="out")
    gain = Param(1.0, minimum=-1e6, maximum=1e6)

    @staticmethod
    def output(x, gain):
        return gain * x


class Sum(Block, name="sum"):
    """out[n] = in[n] − minus[n] (every connection into `in` or `minus` is summed first)."""

    x = In(name="in")
    minus = In()
    y = Out(name="out")

    @staticmethod
    def output(x, minus):
        return x - minus


class Scale(Block, name="scale"):
    """u = (in − a)/(b − a) (clipped to [0, 1] if clip); out = c + u·(d − c) (linear) or c·(d/c)^u (exponential)."""

    x = In(name="in")
    y = Out(name="out")
    in_range = Param([0.0, 1.0], min_items=2, max_items=2, minimum=-1e12, maximum=1e12, doc="[a, b]")
    out_range = Param([0.0, 1.0], min_items=2, max_items=2, minimum=-1e12, maximum=1e12, doc="[c, d]")
    curve = Param("linear", choices=("linear", "exponential"))
    clip = Param(True, doc="clip u to [0, 1]")

    @classmethod
    def check(cls, p, fs):
        if p.in_range[0] == p.in_range[1]:
            yield "in_range", "in_range needs two different values"
        if p.curve == "exponential" and not p.out_range[0] * p.out_range[1] > 0.0:
            yield "out_range", "an exponential curve needs both ends of out_range non-zero and of one sign"

    structure = ("expo", "clipped")     # the curve and the clip are choices; the ranges are data

    @staticmethod
    def derive(p, fs):
        expo = p.curve == "exponential"
        c, d = float(p.out_range[0]), float(p.out_range[1])
        return {"x0": float(p.in_range[0]), "inv_span": 1.0 / (p.in_range[1] - p.in_range[0]),
                "y0": c, "y_span": d - c, "log_ratio": math.log(d / c) if expo else 0.0,
                "expo": expo, "clipped": bool(p.clip)}

    @staticmethod
    def output(x, x0, inv_span, y0, y_span, log_ratio, expo, clipped):
        u = (x - x0) * inv_span
        if clipped:
            u = min(max(u, 0.0), 1.0)
        if expo:
            return y0 * math.exp(u * log_ratio)
        return y0 + u * y_span


class SampleHold(Block, name="sample_hold"):
    """out[n] = out[n−1] while hold[n] > 0.5, else in[n] (suppress, then jump on release)."""

    x = In(name="in")
    hold = In()
    y = Out(name="out")
    held = State(0.0)

    @staticmethod
    def output(x, hold, held):
        return held if hold > 0.5 else x

    @staticmethod
    def update(y):
        return y


class Envelope(Block, name="envelope"):
    """out[n] = g·out[n−1] + (1 − g)·|in[n]|, g = exp(−1/(τ·fs)) with τ = attack while rising, release while falling."""

    x = In(name="in")
    y = Out(name="out")
    attack = Param(0.005, unit="s", minimum=0.0, maximum=60.0, live=False)
    release = Param(0.1, unit="s", minimum=0.0, maximum=60.0, live=False)
    level = State(0.0)

    @staticmethod
    def derive(p, fs):
        return {"g_attack": math.exp(-1.0 / (p.attack * fs)) if p.attack > 0.0 else 0.0,
                "g_release": math.exp(-1.0 / (p.release * fs)) if p.release > 0.0 else 0.0}

    @staticmethod
    def output(x, level, g_attack, g_release):
        a = abs(x)
        g = g_attack if a > level else g_release
        return g * level + (1.0 - g) * a

    @staticmethod
    def update(y):
        return y
