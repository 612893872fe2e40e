"""Signal analysis shared by the physics tests."""
import numpy as np


def estimate_f0(y, fs, fmin=40.0, fmax=2000.0):
    """Fundamental from the autocorrelation's highest peak in [fs/fmax, fs/fmin] lags,
    refined by parabolic interpolation (resolution far below 0.01 sample for a clean tone)."""
    y = np.asarray(y, dtype=np.float64) - np.mean(y)
    n = 1 << int(np.ceil(np.log2(2 * len(y))))
    spec = np.fft.rfft(y, n)
    ac = np.fft.irfft(spec * np.conj(spec), n)[: len(y)]
    ac /= np.arange(len(y), 0, -1)        # unbiased: long lags are not penalised
    lo, hi = int(fs / fmax), int(fs / fmin)
    lag = lo + int(np.argmax(ac[lo:hi]))
    a, b, c = ac[lag - 1], ac[lag], ac[lag + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c)
    return fs / (lag + shift)


def decay_time(envelope, fs, drop_db=20.0):
    """Seconds for a log-envelope line fit to fall by `drop_db`."""
    env = np.asarray(envelope)
    t = np.arange(len(env)) / fs
    keep = env > env.max() * 1e-4
    slope = np.polyfit(t[keep], 20 * np.log10(env[keep]), 1)[0]
    return -drop_db / slope


def spectral_peak(y, fs, fmin, fmax):
    """Frequency of the largest spectral peak in [fmin, fmax] (Hann window, zero-padded 4×,
    parabolic interpolation on the log magnitude): right for dispersive (inharmonic) tones,
    where the autocorrelation's peak is pulled off the fundamental."""
    y = np.asarray(y, dtype=np.float64) - np.mean(y)
    n = 4 * len(y)
    mag = np.abs(np.fft.rfft(y * np.hanning(len(y)), n))
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    band = np.nonzero((freqs >= fmin) & (freqs <= fmax))[0]
    k = band[int(np.argmax(mag[band]))]
    a, b, c = np.log(mag[k - 1: k + 2] + 1e-300)
    return (k + 0.5 * (a - c) / (a - 2 * b + c)) * fs / n
