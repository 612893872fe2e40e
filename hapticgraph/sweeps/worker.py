"""What a sweep's worker does with one variant: load the patch with its overrides, render it
through the engine (one small adapter, `KernelRun`), compute its features and encode its audio;
the row and the audio file's bytes go back to the client, which alone writes the manifest.

A worker process keeps what the variants of a sweep share: the patch's files (files.py), one
block-type registry per patch, and — in graph/kernel — one compiled kernel per structure, so
variants that differ only in numbers (data in the kernel) re-use it. `kernels` tells which
structures this process has used and how many it compiled itself.

Faults stay in the row: a variant the loader refuses is `invalid`, a NaN, an infinity or a value
over the runaway limit is `runaway` (the engine's guard, graph/guard.py), a render past its
`timeout` is ended at the next block boundary (`timeout`), anything else is `error`.
"""
import io
import os
import socket
import time

import numpy as np
import soundfile

from ..devices import DeviceError
from ..devices.wav import audio_format
from ..graph.errors import PatchError
from ..graph.patch import load as load_patch
from ..graph.program import PlanError
from ..graph.registry import Registry
from ..session import SafetyStop, Session
from .features import compute
from .files import materialize

BLOCKSIZE = 4096          # a timeout is seen at the next block boundary: ~0.1 s of audio at 44.1 kHz
RUNAWAY = 1e3             # as `hapticgraph.render`'s safety: a value past it is a runaway

_registries = {}          # patch path -> Registry, in this process
kernels = {"keys": set(), "compiled": 0}      # structures used here, and kernels numba compiled here


class KernelRun:
    """The engine seen by a sweep: a patch's kernel run block by block (hapticgraph.Session)."""

    def __init__(self, patch):
        self.session = Session.open(patch, blocksize=BLOCKSIZE, editable=False, runaway=RUNAWAY)
        self.key, self.compile_seconds = self.session.kernel_key, self.session.compile_seconds
        self.compiled = self.session.compiled
        kernels["compiled"] += self.compiled
        self.new = self.key not in kernels["keys"]
        kernels["keys"].add(self.key)
        self.rate, self.channels = self.session.rate, self.session.channels

    def render(self, seconds, timeout=None):
        """(audio frames × channels, status, error): status ok, runaway or timeout; the audio
        rendered before a fault or the deadline."""
        total = int(round(seconds * self.rate))
        audio = np.zeros((total, self.channels))
        done, start = 0, time.perf_counter()
        try:
            while done < total:
                if timeout is not None and time.perf_counter() - start > timeout:
                    return audio[:done], "timeout", f"rendering took over {timeout:g} s; stopped at " \
                                                    f"{done / self.rate:.3f} s of {seconds:g} s"
                n = min(BLOCKSIZE, total - done)
                try:
                    rec = self.session.process(n)
                except SafetyStop as exc:
                    return audio[:done + exc.kept], "runaway", str(exc)
                audio[done:done + n] = rec[:, :self.channels]
                done += n
        finally:
            self.session.close()
        return audio, "ok", ""


def worker_name():
    """This worker's Dask address (its host and pid outside Dask)."""
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def encode(audio, rate, kind):
    """The audio file's bytes: FLAC (24-bit, clipped at ±1) or WAV (32-bit float), as `run` writes them."""
    fmt, subtype = audio_format(f"x.{kind}")
    data = np.asarray(audio, dtype=np.float32)
    if subtype.startswith("PCM"):
        data = np.clip(data, -1.0, 1.0)
    buf = io.BytesIO()
    soundfile.write(buf, data, int(round(rate)), subtype=subtype, format=fmt)
    return buf.getvalue()


def render_variant(bundle, job, score=None):
    """(row, audio bytes or None) for one variant. `job`: id, overrides, seconds, features
    ({name: function}), audio (flac, wav or none), timeout; `score(audio, rate)`, if given, adds
    columns to the row of a variant that rendered (a fit's distance to its target)."""
    row = {"id": job["id"], "status": "error", "error": "", "audio": "", "seconds_compile": 0.0,
           "seconds_run": 0.0, "worker": worker_name(), "kernel": "", "kernel_new": False,
           "kernel_compiled": False}
    try:
        return _render(bundle, job, row, score)
    except (PatchError, PlanError, DeviceError) as exc:
        row.update(status="invalid", error=_one_line(exc))
    except Exception as exc:  # noqa: BLE001 - a fault is a row; the sweep goes on
        row.update(status="error", error=f"{type(exc).__name__}: {_one_line(exc)}")
    return row, None


def _one_line(exc):
    return " / ".join(str(exc).splitlines()) or type(exc).__name__


def _render(bundle, job, row, score):
    path = materialize(bundle)
    registry = _registries.get(path)
    if registry is None:                        # the entry points are read once per patch, not per variant
        registry = _registries[path] = Registry()
    patch = load_patch(path, overrides=job["overrides"], registry=registry)
    run = KernelRun(patch)
    row.update(seconds_compile=run.compile_seconds, kernel=run.key, kernel_new=run.new, kernel_compiled=run.compiled)
    start = time.perf_counter()
    audio, status, error = run.render(job["seconds"], job.get("timeout"))
    row["seconds_run"] = time.perf_counter() - start
    row.update(status=status, error=error)
    if status != "ok":
        return row, None
    row.update(compute(job["features"], audio, run.rate))
    if score is not None:
        row.update(score(audio, run.rate))
    data = None
    if job["audio"] != "none":
        data = encode(audio, run.rate, job["audio"])
        row["audio"] = f"audio/{job['id']}.{job['audio']}"
    return row, data
