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


class SafetyStop(Exception):
    """The run was stopped to protect the player: a NaN, an infinity, a runaway or a lost device.
    The force sent in the block where it happened was zero."""


class Session:
    """A patch running block by block: the one loop behind both `run` (offline) and `play`
    (an audio callback). Each `process(n)`: edits queued since the last block are applied, the
    drivers fill the device inputs, the kernel runs n samples, the output is checked (NaN,
    infinity, runaway) and the forces go to the drivers — or zeros, and SafetyStop, if the check
    failed or a device was lost. Nothing is allocated per block.
    """

    def __init__(self, patch, probes=(), drivers=None, engine="compiled", blocksize=1 << 14,
                 runaway=1e3, editable=False):
        self.prog = Program(patch, probes, drivers, editable=editable)
        self.runner = make_runner(self.prog, engine)
        self.blocksize = int(blocksize)
        self.runaway = float(runaway)
        prog = self.prog
        self.rec = np.zeros((self.blocksize, len(prog.records)))
        self.ext = np.zeros((self.blocksize, len(prog.ext_columns)))
        self.zeros = np.zeros(self.blocksize)
        columns = {}
        for k, (device, _) in enumerate(prog.ext_columns):
            columns.setdefault(device, []).append(k)
        self.fills = [(prog.drivers[d], slice(cols[0], cols[-1] + 1)) for d, cols in columns.items()]
        self.sends = [(prog.drivers[d], col) for d, col in prog.device_records]
        self.checked = prog.channels + len(probes)   # columns that must stay finite and bounded
        self.t = 0
        self.edits = []
        self.started = False

    @property
    def rate(self):
        return self.prog.rate

    def start(self):
        if not self.started:
            for driver in self.prog.drivers.values():
                driver.start(self.prog.rate)
            self.started = True

    def stop(self):
        if self.started:
            for driver in self.prog.drivers.values():
                driver.stop()
            self.started = False

    def edit(self, fn, *args):
        """Queue a change (e.g. `prog.set_param`) to be applied at the next block boundary."""
        self.edits.append((fn, args))

    def process(self, n):
        """Run the next n (≤ blocksize) samples; returns the view rec[:n] (audio, probes, forces)."""
        if not self.started:
            self.start()
        while self.edits:
            fn, args = self.edits.pop(0)
            fn(*args)
        rec, ext, t0 = self.rec[:n], self.ext[:n], self.t
        for driver, cols in self.fills:
            driver.fill(t0, ext[:, cols])
        self.runner.run(t0, rec, ext)
        self.t = t0 + n
        problem = self._check(rec)
        for driver, col in self.sends:
            if problem is None and not getattr(driver, "lost", False):
                driver.send(t0, rec[:, col])
            else:
                driver.send(t0, self.zeros[:n])
        if problem is None:
            lost = [d for d in self.prog.drivers.values() if getattr(d, "lost", False)]
            if lost:
                problem = f"device {getattr(lost[0], 'name', '?')!r} stopped answering: {lost[0].lost}"
        if problem is not None:
            raise SafetyStop(problem)
        return rec

    def _check(self, rec):
        if not np.isfinite(rec).all():           # one pass; find the culprit only when it fails
            col = int(np.argmin(np.isfinite(rec).all(axis=0)))
            column = rec[:, col]
            i = int(np.argmin(np.isfinite(column)))
            return (f"numerical blow-up: {self.prog.records[col][0]} is {column[i]} at "
                    f"{(self.t - rec.shape[0] + i) / self.rate:.4f} s")
        k = self.checked
        if k and np.isfinite(self.runaway):
            every = rec[:, :k]
            if np.abs(every).max() > self.runaway:
                col = int(np.argmax(np.abs(every).max(axis=0)))
                return (f"runaway: {self.prog.records[col][0]} reached {np.abs(every[:, col]).max():.3g}, "
                        f"over the limit {self.runaway:g}")
        return None


def render(patch, seconds, probes=(), engine="compiled", chunk=1 << 14, progress=None, drivers=None,
           safety=False, runaway=1e3):
    """Render `seconds` of a patch offline; returns a Render.

    `drivers` maps each device name of the patch to a Driver (hapticgraph.render supplies the
    simulated ones); the kernel runs in chunks, the drivers exchange inputs and forces between.
    A block with a NaN, an infinity or (with `safety`) a value over `runaway` sends zero force.
    With `safety` the render then stops: SafetyStop is raised with `.result`, the Render of
    everything before that block (its audio is not worth keeping). A lost device always stops it.
    """
    if engine == "python":
        chunk = min(chunk, 4096)
    session = Session(patch, probes, drivers, engine, blocksize=chunk, runaway=runaway if safety else np.inf)
    prog = session.prog
    total = int(round(seconds * prog.rate))
    rec = np.zeros((total, len(prog.records)))
    bar = Progress(total, f"rendering {patch.name}", enabled=progress)
    start = time.perf_counter()

    def result(upto):
        audio = np.ascontiguousarray(rec[:upto, :prog.channels])
        probed = {label: rec[:upto, prog.channels + k].copy() for k, label in enumerate(probes)}
        return Render(audio, probed, prog.rate, session.runner.compile_seconds, time.perf_counter() - start)

    try:
        for begin in range(0, total, chunk):
            end = min(total, begin + chunk)
            try:
                rec[begin:end] = session.process(end - begin)
            except SafetyStop as stop:
                rec[begin:end] = session.rec[: end - begin]
                if safety or any(getattr(d, "lost", False) for d in prog.drivers.values()):
                    stop.result = result(begin)
                    raise
            except KeyboardInterrupt as interrupt:
                interrupt.result = result(begin)
                raise
            bar(end)
    finally:
        session.stop()
    return result(total)
