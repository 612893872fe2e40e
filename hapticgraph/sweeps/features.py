"""Audio features of a render: one number each, what a sweep's manifest and a fit compare.

A feature is a function `fn(audio, rate) -> float` (audio: frames × channels, or one channel, in
any float type; rate in Hz). The built-in ones are registered by `register_feature`, the same way
a plugin registers one; installed packages add theirs through the entry-point group
`hapticgraph.features` (`name = "module:function"`), read once, when the table is first asked for.

- `f0` [Hz]: the fundamental, by YIN's cumulative mean normalised difference (de Cheveigné and
  Kawahara 2002) over up to 2^15 samples from the onset, with parabolic interpolation; NaN for
  silence or when nothing is periodic between 20 Hz and 5 kHz.
- `t60` [s]: the time the level takes to fall by 60 dB, from the slope of a straight line fitted to
  the level in dB of 10 ms frames, from the loudest frame to the last frame within 80 dB of it
  (inf when it does not fall, or falls by less than 1 dB in 1000 s).
- `centroid` [Hz]: the spectral centroid, Σ f·|X(f)| / Σ |X(f)| of the Hann-windowed signal.
- `rms`, `peak`: the root mean square and the largest magnitude of every sample of every channel.
- `inharmonicity` (B): partials f_n = n·f0·√(1 + B·n²) of a stiff string (Fletcher 1964):
  the partials are found one after another, each predicted by the fit of those before, and B is
  the slope over the intercept of the straight line (f_n/n)² = f0² + f0²·B·n².

f0, t60, centroid and inharmonicity read the mono mix (the mean of the channels).
"""
import math

import numpy as np

_table = {}
_entry_points_read = []
ENTRY_POINT_GROUP = "hapticgraph.features"


def register_feature(name, fn):
    """Add (or replace) a feature: `fn(audio, rate) -> float`. Names are identifiers."""
    if not (isinstance(name, str) and name.isidentifier()):
        raise ValueError(f"feature name {name!r} is not an identifier")
    if not callable(fn):
        raise TypeError(f"feature {name!r}: {fn!r} is not callable")
    _table[name] = fn
    return fn


def feature_table():
    """Every feature by name: the built-in ones and those of the `hapticgraph.features` entry points."""
    if not _entry_points_read:
        _entry_points_read.append(True)
        import importlib.metadata
        for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            try:
                register_feature(ep.name, ep.load())
            except Exception as exc:  # noqa: BLE001 - a broken plugin must not hide the rest
                import sys
                print(f"hapticgraph: warning: feature entry point {ep.name!r} failed to load: "
                      f"{type(exc).__name__}: {exc}", file=sys.stderr)
    return dict(_table)


def compute(features, audio, rate):
    """{name: value} for a {name: function} (or a list of names) on one render's audio."""
    if not isinstance(features, dict):
        table = feature_table()
        features = {name: table[name] for name in features}
    return {name: float(fn(audio, rate)) for name, fn in features.items()}


def mono(audio):
    """The mean of the channels, float64."""
    a = np.asarray(audio, dtype=np.float64)
    return a if a.ndim == 1 else a.mean(axis=1)


def rms(audio, rate):
    a = np.asarray(audio, dtype=np.float64)
    return math.sqrt(float(np.mean(a * a))) if a.size else math.nan


def peak(audio, rate):
    a = np.asarray(audio, dtype=np.float64)
    return float(np.max(np.abs(a))) if a.size else math.nan


def _onset(x):
    """The first sample within 40 dB of the peak (0 for silence)."""
    top = np.max(np.abs(x)) if x.size else 0.0
    if top <= 0:
        return 0
    return int(np.argmax(np.abs(x) >= top * 0.01))


def _difference(x, lag_max):
    """YIN's difference function d(τ), τ = 0 … lag_max, over the first len(x) − lag_max samples."""
    width = len(x) - lag_max
    size = 1 << int(math.ceil(math.log2(len(x) + width)))
    spectrum = np.fft.rfft(x, size)
    head = np.fft.rfft(x[:width], size)
    corr = np.fft.irfft(spectrum * np.conj(head), size)[:lag_max + 1]   # Σ_j x_j x_{j+τ}, j < width
    squares = np.concatenate(([0.0], np.cumsum(x * x)))
    energy0 = squares[width]
    energy = squares[width:width + lag_max + 1] - squares[:lag_max + 1]  # Σ_j x_{j+τ}², j < width
    return np.maximum(energy0 + energy - 2.0 * corr, 0.0)


def _parabola(y, k):
    """The offset (−½ … ½) of the extremum of the parabola through y[k−1], y[k], y[k+1]."""
    if k <= 0 or k >= len(y) - 1:
        return 0.0
    a, b, c = y[k - 1], y[k], y[k + 1]
    den = a - 2.0 * b + c
    return 0.0 if den == 0 else 0.5 * (a - c) / den


def f0(audio, rate, fmin=20.0, fmax=5000.0, threshold=0.1):
    x = mono(audio)
    x = x[_onset(x):][:1 << 15]
    lag_max = min(int(rate / fmin), len(x) // 2)
    lag_min = max(2, int(rate / fmax))
    if lag_max <= lag_min + 2 or not np.any(x):
        return math.nan
    d = _difference(x, lag_max)
    total = np.cumsum(d[1:])
    cmnd = np.ones_like(d)
    cmnd[1:] = d[1:] * np.arange(1, lag_max + 1) / np.where(total > 0, total, 1.0)
    below = np.nonzero(cmnd[lag_min:lag_max] < threshold)[0]
    if below.size:
        k = lag_min + int(below[0])
        while k + 1 < lag_max and cmnd[k + 1] < cmnd[k]:
            k += 1
    else:
        k = lag_min + int(np.argmin(cmnd[lag_min:lag_max]))
        if cmnd[k] > 0.5:
            return math.nan             # nothing periodic
    return float(rate / (k + _parabola(cmnd, k)))


def t60(audio, rate, frame_seconds=0.01, span_db=80.0):
    x = mono(audio)
    size = max(1, int(round(frame_seconds * rate)))
    frames = len(x) // size
    if frames < 3:
        return math.nan
    power = np.mean(x[:frames * size].reshape(frames, size) ** 2, axis=1)
    top = int(np.argmax(power))
    if power[top] <= 0:
        return math.nan
    level = 10.0 * np.log10(np.maximum(power, power[top] * 1e-30) / power[top])
    alive = np.nonzero(level[top:] >= -span_db)[0]
    last = top + int(alive[-1])
    if last - top < 2:
        return math.nan
    times = np.arange(top, last + 1) * (size / rate)
    slope = np.polyfit(times, level[top:last + 1], 1)[0]      # dB per second
    return float(-60.0 / slope) if slope < -1e-3 else math.inf     # slower than 60 dB a day: steady


def _spectrum(x, rate, pad=4):
    size = 1 << int(math.ceil(math.log2(max(len(x), 2) * pad)))
    mag = np.abs(np.fft.rfft(x * np.hanning(len(x)), size))
    return mag, rate / size


def centroid(audio, rate):
    x = mono(audio)
    mag, step = _spectrum(x, rate, pad=1)
    total = float(np.sum(mag))
    if total <= 0:
        return math.nan
    return float(np.sum(np.arange(len(mag)) * step * mag) / total)


def _partial(mag, step, guess, width):
    """The frequency of the largest peak of mag within guess ± width, refined on the log magnitude
    (None if the window holds no local maximum)."""
    lo, hi = max(1, int((guess - width) / step)), min(len(mag) - 2, int((guess + width) / step))
    if hi <= lo:
        return None
    k = lo + int(np.argmax(mag[lo:hi + 1]))
    if k in (lo, hi) and not (mag[k] >= mag[k - 1] and mag[k] >= mag[k + 1]):
        return None
    log = np.log(np.maximum(mag[k - 1:k + 2], 1e-300))
    return (k + _parabola(log, 1)) * step, mag[k]


def inharmonicity(audio, rate, partials=16, floor_db=-80.0):
    x = mono(audio)
    guess = f0(x, rate)
    if not math.isfinite(guess):
        return math.nan
    mag, step = _spectrum(x, rate)
    floor = float(np.max(mag)) * 10.0 ** (floor_db / 20.0)
    base, b = guess, 0.0
    orders, freqs = [], []
    for n in range(1, partials + 1):
        predicted = n * base * math.sqrt(1.0 + b * n * n)
        if predicted + base / 3 >= rate / 2:
            break
        found = _partial(mag, step, predicted, base / 3)
        if found is None or found[1] < floor:
            continue
        orders.append(n)
        freqs.append(found[0])
        if len(orders) >= 3:
            base, b = _fit_stiff(orders, freqs)
        elif n == 1:
            base = found[0]
    if len(orders) < 3:
        return math.nan
    return float(_fit_stiff(orders, freqs)[1])


def _fit_stiff(orders, freqs):
    """(f0, B) of the least-squares line (f_n/n)² = f0² + f0²·B·n²."""
    n = np.asarray(orders, dtype=np.float64)
    y = (np.asarray(freqs) / n) ** 2
    slope, intercept = np.polyfit(n * n, y, 1)
    if intercept <= 0:
        return float(freqs[0] / orders[0]), 0.0
    return math.sqrt(intercept), float(slope / intercept)


for _name, _fn in (("f0", f0), ("t60", t60), ("centroid", centroid), ("rms", rms), ("peak", peak),
                   ("inharmonicity", inharmonicity)):
    register_feature(_name, _fn)

__all__ = ["register_feature", "feature_table", "compute", "mono", "f0", "t60", "centroid", "rms", "peak",
           "inharmonicity", "ENTRY_POINT_GROUP"]
