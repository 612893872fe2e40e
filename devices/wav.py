"""WAV files: 32-bit float out (what `run` writes), any PCM or float in."""
import numpy as np
from scipy.io import wavfile


def write_wav(path, audio, rate):
    """Write frames × channels as 32-bit IEEE float WAV at an integer rate."""
    audio = np.asarray(audio, dtype=np.float32)
    if audio.ndim == 1:
        audio = audio[:, None]
    wavfile.write(path, int(round(rate)), audio)


def read_wav(path):
    """(float64 frames × channels scaled to ±1, rate)."""
    rate, data = wavfile.read(path)
    if data.dtype.kind == "i":
        data = data / float(np.iinfo(data.dtype).max)
    elif data.dtype.kind == "u":
        data = (data.astype(np.float64) - 128.0) / 128.0
    data = np.asarray(data, dtype=np.float64)
    if data.ndim == 1:
        data = data[:, None]
    return data, rate
