"""The driver of `driver: sine`: the hand's position and velocity, sample by sample, into the
haptic block's sensor columns; the force the patch sends back (already clamped to max_force by
the kernel) is felt, and its peak kept."""
import math

import numpy as np

from hapticgraph.graph.engine import Driver


class SineHand(Driver):
    columns = ("sensor_x", "sensor_v")

    def __init__(self, name, frequency, amplitude, max_force):
        self.name, self.frequency, self.amplitude = name, float(frequency), float(amplitude)
        self.max_force = float(max_force)
        self.rate, self.peak = 44100.0, 0.0
        self.phase = np.zeros(0)

    def start(self, rate):
        self.rate, self.peak = float(rate), 0.0

    def fill(self, t0, ext):
        n = ext.shape[0]
        if len(self.phase) != n:
            self.phase = np.empty(n)
        w = 2.0 * math.pi * self.frequency
        np.multiply(np.arange(t0, t0 + n, dtype=np.float64), w / self.rate, out=self.phase)
        np.sin(self.phase, out=ext[:, 0])
        ext[:, 0] *= self.amplitude
        np.cos(self.phase, out=ext[:, 1])
        ext[:, 1] *= self.amplitude * w

    def send(self, t0, force):
        if len(force):
            self.peak = max(self.peak, float(np.max(np.abs(force))))
