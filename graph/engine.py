"""The offline engine: run a patch's kernel (or the reference interpreter) in chunks, as fast as
possible, and collect the audio and the probes."""
import sys
import time

import numpy as np

from .interpreter import Interpreter
from .kernel import CompiledKernel
from .program import Program

ENGINES = ("compiled", "python")


class Render:
    """What `render` returns: `audio` (frames × channels), `probes` (name → array), `rate`."""

    def __init__(self, audio, probes, rate, compile_seconds=0.0, run_seconds=0.0):
        self.audio, self.probes, self.rate = audio, probes, rate
        self.compile_seconds, self.run_seconds = compile_seconds, run_seconds


def make_runner(prog, engine="compiled"):
    if engine == "compiled":
        return CompiledKernel(prog)
    if engine == "python":
        return Interpreter(prog)
    raise ValueError(f"unknown engine {engine!r}; use one of {', '.join(ENGINES)}")


class Progress:
    """A one-line progress bar on an interactive stderr; silent otherwise."""

    def __init__(self, total, label, enabled=None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total, self.label, self.start = total, label, time.perf_counter()

    def __call__(self, done):
        if not self.enabled or self.total <= 0:
            return
        frac = done / self.total
        bar = "#" * int(30 * frac)
        self.stream.write(f"\r{self.label} [{bar:<30}] {100 * frac:5.1f}% "
                          f"{time.perf_counter() - self.start:6.1f} s")
        if done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def render(patch, seconds, probes=(), engine="compiled", chunk=1 << 16, progress=None):
    """Render `seconds` of a patch offline; returns a Render."""
    prog = Program(patch, probes)
    runner = make_runner(prog, engine)
    total = int(round(seconds * prog.rate))
    rec = np.zeros((total, len(prog.records)))
    if engine == "python":
        chunk = min(chunk, 4096)
    bar = Progress(total, f"rendering {patch.name}", enabled=progress)
    start = time.perf_counter()
    for begin in range(0, total, chunk):
        end = min(total, begin + chunk)
        runner.run(begin, rec[begin:end])
        bar(end)
    elapsed = time.perf_counter() - start
    audio = np.ascontiguousarray(rec[:, :prog.channels])
    probed = {label: rec[:, k].copy() for k, (label, _) in enumerate(prog.records) if k >= prog.channels}
    return Render(audio, probed, prog.rate, runner.compile_seconds, elapsed)
