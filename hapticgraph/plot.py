"""`hapticgraph plot`: probe traces over a time window and a spectrogram, as a PNG (matplotlib).

Every axis carries a quantity and a unit: time [s], frequency [Hz], and for a probe the quantity
its block declares (a port's doc ending in "[unit]", a parameter's `unit`), else its name.
"""
import re

import numpy as np

MISSING = 'plot needs matplotlib: pip install "hapticgraph[plot]"'

# unit -> the quantity a port in that unit measures, when its doc does not name one we know
_QUANTITY = {"m": "position", "m/s": "velocity", "N": "force", "Pa": "pressure", "kg": "mass",
             "N/m": "stiffness", "N·s/m": "damping", "Hz": "frequency", "s": "time"}
_WORDS = ("displacement", "position", "velocity", "force", "pressure")
_UNIT = re.compile(r"\[([^\[\]]+)\]\s*(?:[;,.].*)?$")


class MatplotlibMissing(ImportError):
    pass


def pyplot():
    """matplotlib.pyplot on the Agg backend, or MatplotlibMissing with the install hint."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise MatplotlibMissing(MISSING) from None
    return plt


def quantity_of(patch, probe):
    """(quantity, unit) of a probe `BLOCK.PORT` or `BLOCK[i, ...].PORT` from its block's
    declaration: ("force", "N"), ("velocity", "m/s"), ...; ("", "") when the block says nothing."""
    block, _, port = probe.rpartition(".")
    block = block.split("[", 1)[0].strip()
    inst = getattr(patch, "blocks", {}).get(block)
    if inst is None:
        return "", ""
    doc = unit = ""
    ports = list(inst.outputs) + list(inst.inputs)
    if getattr(inst.cls, "family", None) is not None and getattr(inst.cls, "check_cell", None):   # a lattice's cells
        from .blocks.lattice import Cell
        ports += list(Cell.outputs) + list(Cell.inputs)
    for p in ports:
        if p.name == port:
            doc = getattr(p, "doc", "") or ""
            m = _UNIT.search(doc)
            unit = m.group(1).strip() if m else ""
            break
    else:
        param = inst.cls.params.get(port)
        if param is not None:
            doc, unit = param.doc or "", param.unit or ""
    if not unit:
        return "", ""
    lower = doc.lower()
    word = next((w for w in _WORDS if w in lower), None)
    if word is None or (unit == "m" and word not in ("displacement", "position")):
        word = _QUANTITY.get(unit, "")
    return word, unit


def probe_label(patch, probe):
    """The y label of a probe's trace: its name and, where known, `quantity [unit]`."""
    quantity, unit = quantity_of(patch, probe) if patch is not None else ("", "")
    return f"{probe}\n{quantity} [{unit}]" if unit else probe


def plot_render(result, probes, out, title="", window=None, spectrogram=None, width=9.0, patch=None):
    """Draw each probe over `window` (t0, t1 in s) and a spectrogram of `spectrogram`
    ("audio", a probe name, or None for no spectrogram) into the PNG `out`; `patch` gives each
    probe's quantity and unit."""
    plt = pyplot()
    rate = result.rate
    n = result.audio.shape[0] if result.audio.size else len(next(iter(result.probes.values())))
    t = np.arange(n) / rate
    t0, t1 = window if window else (0.0, n / rate)
    sel = (t >= t0) & (t <= t1)
    rows = len(probes) + (1 if spectrogram else 0)
    fig, axes = plt.subplots(rows, 1, figsize=(width, 1.9 * rows + 0.6), squeeze=False, sharex=False)
    axes = axes[:, 0]
    for ax, name in zip(axes, probes):
        ax.plot(t[sel], result.probes[name][sel], lw=0.8)
        ax.set_ylabel(probe_label(patch, name), fontsize=8)
        ax.grid(alpha=0.3)
        ax.set_xlim(t0, t1)
        ax.set_xlabel("time [s]", fontsize=8)
    if spectrogram:
        ax = axes[-1]
        signal = result.audio.mean(axis=1) if spectrogram == "audio" else result.probes[spectrogram]
        nfft = 1024 if rate >= 16000 else 512
        if len(signal) > nfft:
            with np.errstate(divide="ignore"):   # silent stretches have zero power
                _, _, _, image = ax.specgram(signal, NFFT=nfft, Fs=rate, noverlap=nfft * 3 // 4,
                                             cmap="magma", scale="dB")
            top = image.get_clim()[1]
            image.set_clim(top - 100.0, top)      # 100 dB of range: silence would stretch it to −300
            fig.colorbar(image, ax=ax, pad=0.01, label="power [dB]")
        ax.set_ylabel(f"{spectrogram}\nfrequency [Hz]", fontsize=8)
        ax.set_xlabel("time [s]", fontsize=8)
        ax.set_ylim(0, min(rate / 2, 8000))
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_mode(freq, shape, out, title="", width=7.0):
    """Draw one mode shape: a line for a 1-D lattice, a map for 2-D, the middle slice beyond."""
    plt = pyplot()
    shape = np.asarray(shape, dtype=float)
    while shape.ndim > 2:                      # the middle slice of every further axis
        shape = shape[..., shape.shape[-1] // 2]
    fig, ax = plt.subplots(figsize=(width, 3.2 if shape.ndim < 2 else width * 0.8))
    if shape.ndim <= 1:
        ax.plot(np.arange(shape.size), shape.ravel(), "o-", ms=3)
        ax.axhline(0, color="0.6", lw=0.5)
        ax.set_xlabel("cell index i")
        ax.set_ylabel("displacement (normalised to peak 1)")
    else:
        lim = np.nanmax(np.abs(shape)) or 1.0
        im = ax.imshow(shape, cmap="RdBu_r", vmin=-lim, vmax=lim, origin="upper")
        fig.colorbar(im, ax=ax, shrink=0.8, label="displacement (normalised to peak 1)")
        ax.set_xlabel("cell index j (axis 1)")
        ax.set_ylabel("cell index i (axis 0)")
    ax.set_title(f"{title} {freq:.2f} Hz".strip(), fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
