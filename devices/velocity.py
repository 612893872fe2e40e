"""The velocity of a device that reports only its position, estimated: a one-pole lowpass of the
position's difference quotient,

    v_k = v_{k−1} + a·((x_k − x_{k−1})/Δt − v_{k−1}),  a = 1 − exp(−2π·f_c·Δt),

the first position giving a quotient of 0. A step with no new position (a report-on-change
device gone quiet) decays it towards 0, and it is 0 below 1e-9 m/s (at rest). The HID drivers
(hid_reports, hid_layout: one step a report interval) and the evdev driver (one step a block of
samples) share it.
"""
import math

AT_REST = 1e-9          # m/s: below it a decaying estimate is 0 (and no more steps are needed)


def smoothing(cutoff, dt):
    """a for a cutoff of `cutoff` Hz at steps of `dt` s (1: no smoothing, when cutoff ≤ 0)."""
    return 1.0 - math.exp(-2.0 * math.pi * cutoff * dt) if cutoff > 0 else 1.0


class VelocityEstimate:
    """The estimate at `cutoff` Hz, for steps of `interval` s (or of a `dt` given at each step)."""

    def __init__(self, cutoff, interval=None):
        self.cutoff, self.interval = cutoff, interval
        self.alpha = smoothing(cutoff, interval) if interval else None
        self.reset()

    def reset(self):
        self.x_prev, self.v = None, 0.0

    def step(self, x, dt=None):
        """A new position `x`, `dt` s after the last one (the interval when not given): v."""
        if dt is None:
            dt, alpha = self.interval, self.alpha
        else:
            alpha = smoothing(self.cutoff, dt)
        raw = 0.0 if self.x_prev is None else (x - self.x_prev) / dt
        self.v += alpha * (raw - self.v)
        self.x_prev = x
        return self.v

    def decay(self):
        """A step with no new position: True if the estimate moved (it was not at rest)."""
        if self.x_prev is None or self.v == 0.0:
            return False
        self.v += self.alpha * (0.0 - self.v)
        if abs(self.v) < AT_REST:
            self.v = 0.0
        return True


__all__ = ["AT_REST", "VelocityEstimate", "smoothing"]
