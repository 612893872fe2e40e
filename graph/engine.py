"""The offline engine: run a patch's kernel (or the reference interpreter) in chunks, as fast as
possible, and collect the audio and the probes."""
import sys
import time

import numpy as np

from .interpreter import Interpreter
from .kernel import CompiledKernel
from .program import Program

ENGINES = ("compiled", "python")


class Driver:
    """What the engine asks of a device; hapticgraph.devices implements it (simulated, HID, replay).

    `columns` names the per-sample inputs it supplies (the External attributes of its block type);
    `block_type`, if set, replaces the patch's block bound to the device (a device model);
    `block_values()` gives that block's internal parameters (e.g. max_force).
    Before each block of samples `fill(t0, ext)` writes the inputs of samples t0 … t0+n−1 into
    `ext` (n × len(columns)); after it `send(t0, force)` receives the force the patch put out,
    which the driver clamps to its device's max_force before anything reaches a hand.
    """

    columns = ()
    block_type = None

    def block_values(self):
        return {}

    def start(self, rate):
        pass

    def fill(self, t0, ext):
        pass

    def send(self, t0, force):
        pass

    def stop(self):
        pass


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


def render(patch, seconds, probes=(), engine="compiled", chunk=1 << 14, progress=None, drivers=None):
    """Render `seconds` of a patch offline; returns a Render.

    `drivers` maps each device name of the patch to a Driver (hapticgraph.render supplies the
    simulated ones); the kernel runs in chunks, the drivers exchange inputs and forces between.
    """
    prog = Program(patch, probes, drivers)
    runner = make_runner(prog, engine)
    total = int(round(seconds * prog.rate))
    rec = np.zeros((total, len(prog.records)))
    if engine == "python":
        chunk = min(chunk, 4096)
    ext = np.zeros((min(chunk, max(total, 1)), len(prog.ext_columns)))
    columns = {}
    for k, (device, _) in enumerate(prog.ext_columns):
        columns.setdefault(device, []).append(k)
    sends = [(prog.drivers[d], col) for d, col in prog.device_records]
    for driver in prog.drivers.values():
        driver.start(prog.rate)
    bar = Progress(total, f"rendering {patch.name}", enabled=progress)
    start = time.perf_counter()
    try:
        for begin in range(0, total, chunk):
            end = min(total, begin + chunk)
            block = ext[: end - begin]
            for device, cols in columns.items():
                prog.drivers[device].fill(begin, block[:, cols[0]:cols[-1] + 1])
            runner.run(begin, rec[begin:end], block)
            for driver, col in sends:
                driver.send(begin, rec[begin:end, col])
            bar(end)
    finally:
        for driver in prog.drivers.values():
            driver.stop()
    elapsed = time.perf_counter() - start
    audio = np.ascontiguousarray(rec[:, :prog.channels])
    probed = {label: rec[:, prog.channels + k].copy() for k, label in enumerate(probes)}
    return Render(audio, probed, prog.rate, runner.compile_seconds, elapsed)
