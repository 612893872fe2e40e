"""Drivers that feed a patch from files: a WAV file into an `audio_in` block."""
import os

import numpy as np

from ..graph.engine import Driver
from .wav import read_wav


class WavInput(Driver):
    """Plays one channel of a WAV file into an audio_in block, resampled (linearly) to the patch rate."""

    columns = ("sample",)

    def __init__(self, path, channel=0, loop=False):
        data, rate = read_wav(path)
        if channel >= data.shape[1]:
            raise ValueError(f"{os.path.basename(path)} has {data.shape[1]} channel(s); channel {channel} asked")
        self.data, self.file_rate, self.loop = data[:, channel].copy(), float(rate), loop
        self.signal = self.data

    def start(self, rate):
        if rate != self.file_rate and len(self.data) > 1:
            n = int(round(len(self.data) * rate / self.file_rate))
            self.signal = np.interp(np.arange(n) * self.file_rate / rate, np.arange(len(self.data)), self.data)
        else:
            self.signal = self.data

    def fill(self, t0, ext):
        n = ext.shape[0]
        idx = t0 + np.arange(n)
        if self.loop and len(self.signal):
            ext[:, 0] = self.signal[idx % len(self.signal)]
        else:
            ext[:, 0] = 0.0
            inside = idx < len(self.signal)
            ext[inside, 0] = self.signal[idx[inside]]
