"""`hapticgraph plot`: probe traces over a time window and a spectrogram, as a PNG (matplotlib)."""
import numpy as np


def plot_render(result, probes, out, title="", window=None, spectrogram=None, width=9.0):
    """Draw each probe over `window` (t0, t1 in s) and a spectrogram of `spectrogram`
    ("audio", a probe name, or None for no spectrogram) into the PNG `out`."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise RuntimeError("plotting needs matplotlib: pip install 'hapticgraph[plot]'") from exc
    rate = result.rate
    n = result.audio.shape[0] if result.audio.size else len(next(iter(result.probes.values())))
    t = np.arange(n) / rate
    t0, t1 = window if window else (0.0, n / rate)
    sel = (t >= t0) & (t <= t1)
    rows = len(probes) + (1 if spectrogram else 0)
    fig, axes = plt.subplots(rows, 1, figsize=(width, 1.9 * rows + 0.6), squeeze=False, sharex=False)
    axes = axes[:, 0]
    for ax, name in zip(axes, probes):
        ax.plot(t[sel] * 1e3, result.probes[name][sel], lw=0.8)
        ax.set_ylabel(name, fontsize=8)
        ax.grid(alpha=0.3)
        ax.set_xlim(t0 * 1e3, t1 * 1e3)
    if probes:
        axes[len(probes) - 1].set_xlabel("time [ms]")
    if spectrogram:
        ax = axes[-1]
        signal = result.audio.mean(axis=1) if spectrogram == "audio" else result.probes[spectrogram]
        nfft = 1024 if rate >= 16000 else 512
        if len(signal) > nfft:
            with np.errstate(divide="ignore"):   # silent stretches have zero power
                    ax.specgram(signal, NFFT=nfft, Fs=rate, noverlap=nfft * 3 // 4, cmap="magma",
                            scale="dB")
        ax.set_ylabel(f"{spectrogram}\nfrequency [Hz]", fontsize=8)
        ax.set_xlabel("time [s]")
        ax.set_ylim(0, min(rate / 2, 8000))
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_mode(freq, shape, out, title="", width=7.0):
    """Draw one mode shape: a line for a 1-D lattice, a map for 2-D, the middle slice beyond."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    shape = np.asarray(shape, dtype=float)
    while shape.ndim > 2:                      # the middle slice of every further axis
        shape = shape[..., shape.shape[-1] // 2]
    fig, ax = plt.subplots(figsize=(width, 3.2 if shape.ndim < 2 else width * 0.8))
    if shape.ndim <= 1:
        ax.plot(np.arange(shape.size), shape.ravel(), "o-", ms=3)
        ax.axhline(0, color="0.6", lw=0.5)
        ax.set_xlabel("cell")
        ax.set_ylabel("displacement (normalised)")
    else:
        lim = np.nanmax(np.abs(shape)) or 1.0
        im = ax.imshow(shape, cmap="RdBu_r", vmin=-lim, vmax=lim, origin="upper")
        fig.colorbar(im, ax=ax, shrink=0.8, label="displacement (normalised)")
        ax.set_xlabel("axis 1")
        ax.set_ylabel("axis 0")
    ax.set_title(f"{title} {freq:.2f} Hz".strip(), fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
