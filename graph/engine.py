"""The offline engine: run a patch's kernel (or the reference interpreter) block by block, as fast
as possible, and hand each block to a sink: `render` keeps arrays, `run` streams files
(hapticgraph.devices.files.FileSink), so memory stays flat whatever the length."""
import sys
import threading
import time
import warnings

import numpy as np

from .interpreter import Interpreter
from .isolate import compiled
from .program import Program
from .progress import progress_bar

ENGINES = ("compiled", "python")
STOP_SECONDS = 5.0      # how long a device may take to stop before it is abandoned (Runner.stop)


class Driver:
    """What the engine asks of a device; hapticgraph.devices implements it (simulated, HID, replay).

    What a driver knows before it runs (its device entry's settings and checks, the axes it
    offers) is its driver kind's, which the caller hands the loader (hapticgraph.graph.registry);
    graph/ names no driver.

    `columns` names the per-sample inputs it supplies (the External attributes of its block type);
    `block_type`, if set, replaces the patch's block bound to the device (a device model);
    `block_values()` gives that block's internal parameters (e.g. max_force).
    Before each block of samples `fill(t0, ext)` writes the inputs of samples t0 … t0+n−1 into
    `ext` (n × len(columns)); after it `send(t0, force)` receives the force the patch put out,
    already clamped by the kernel to the driver's `max_force` (its attribute, else
    `block_values()['max_force']`; none: no clamp) and zero after a fault, which the driver clamps
    again before anything reaches a hand. `lost`, when a driver has it, is None or why its
    device stopped answering.
    """

    columns = ()
    block_type = None
    lost = None      # a class attribute, so the per-call check finds it at once

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


def stop_driver(name, driver, seconds=None):
    """`driver.stop()` on a thread of its own, waited for `seconds` (STOP_SECONDS): no device can
    keep a run from ending. Past that the device is abandoned — its thread left running, a daemon
    — with one line on stderr naming it; False. An exception from `stop` is raised here."""
    failed = []

    def run():
        try:
            driver.stop()
        except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
            failed.append(exc)
    seconds = STOP_SECONDS if seconds is None else seconds
    thread = threading.Thread(target=run, daemon=True, name=f"stop {name}")
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        print(f"hapticgraph: device {name!r} did not close within {seconds:g} s: abandoned", file=sys.stderr)
        return False
    if failed:
        raise failed[0]
    return True


class Render:
    """What `render` returns: `audio` (frames × channels), `probes` (name → array), `rate`."""

    def __init__(self, audio, probes, rate, compile_seconds=0.0, run_seconds=0.0):
        self.audio, self.probes, self.rate = audio, probes, rate
        self.compile_seconds, self.run_seconds = compile_seconds, run_seconds


def make_engine(prog, engine="compiled"):
    """What `engine` names: the compiled kernel ("compiled") or the reference interpreter
    ("python"), both with `run(t0, rec, ext)`."""
    if engine == "compiled":
        return compiled(prog)       # a plugin block numba cannot compile: PatchError at its line
    if engine == "python":
        return Interpreter(prog)
    raise ValueError(f"unknown engine {engine!r}; use one of {', '.join(ENGINES)}")



class SafetyStop(Exception):
    """The run was stopped to protect the player: a NaN, an infinity, a runaway or a lost device.
    The force sent in the block where it happened was zero. `kept`: the samples of that block
    rendered before the one where it was caught (0 for a lost device: its inputs are stale)."""

    def __init__(self, message, kept=0):
        super().__init__(message)
        self.kept = kept


class Runner:
    """The runner of one program (graph/program.py) on one engine (`engine`: the compiled kernel
    or the interpreter): a patch running block by block, the one loop behind both `run` (offline) and `play`
    (an audio callback). Each `process(n)`: edits queued since the last block are applied, the
    drivers fill the device inputs, the kernel runs n samples and checks them itself (its guard,
    graph/guard.py: a NaN or an infinity anywhere; a runaway in the audio or in a force sent to a
    device — never in a probe, which may watch anything — and each force clamped to its device's
    max_force), and the forces go to the drivers — zeros, and SafetyStop, if the check failed (the
    kernel zeroed them) or a device was lost. Nothing is allocated per block: the views of a
    block size are made once. Programs use it through hapticgraph.Session, the public door.
    """

    def __init__(self, patch, probes=(), drivers=None, engine="compiled", blocksize=1 << 14,
                 runaway=1e3, editable=False):
        self.prog = Program(patch, probes, drivers, editable=editable)
        self.engine = make_engine(self.prog, engine)
        self.blocksize = int(blocksize)
        self.runaway = float(runaway)
        prog = self.prog
        prog.guard.set_runaway(self.runaway)
        self.rec = np.zeros((self.blocksize, len(prog.records)))
        self.ext = np.zeros((self.blocksize, len(prog.ext_columns)))
        self.zeros = np.zeros(self.blocksize)
        columns = {}
        for k, (device, _) in enumerate(prog.ext_columns):
            columns.setdefault(device, []).append(k)
        self.fills = [(prog.drivers[d], slice(cols[0], cols[-1] + 1)) for d, cols in columns.items()]
        self.sends = [(prog.drivers[d], col) for d, col in prog.device_records]
        self.drivers = tuple(prog.drivers.values())
        self.views = None     # (n, rec[:n], ext[:n], [(driver, its ext columns)], [(driver, force, zeros)])
        self.t = 0
        self.edits = []
        self.started = False

    @property
    def rate(self):
        return self.prog.rate

    def start(self):
        if not self.started:
            for driver in self.drivers:
                driver.start(self.prog.rate)
            self.started = True

    def stop(self):
        """Stop every driver, each within STOP_SECONDS (hapticgraph.graph.engine.stop_driver)."""
        if self.started:
            for name, driver in self.prog.drivers.items():
                stop_driver(name, driver)
            self.started = False

    def edit(self, fn, *args):
        """Queue a change (e.g. `prog.set_param`) to be applied at the next block boundary."""
        self.edits.append((fn, args))

    def _views(self, n):
        rec, ext = self.rec[:n], self.ext[:n]
        self.views = (n, rec, ext, [(driver, ext[:, cols]) for driver, cols in self.fills],
                      [(driver, rec[:, col], self.zeros[:n]) for driver, col in self.sends])
        return self.views

    def process(self, n):
        """Run the next n (≤ blocksize) samples; returns the view rec[:n] (audio, probes, forces)."""
        if not self.started:
            self.start()
        while self.edits:
            fn, args = self.edits.pop(0)
            fn(*args)
        views = self.views
        if views is None or views[0] != n:
            views = self._views(n)
        _, rec, ext, fills, sends = views
        t0 = self.t
        for driver, columns in fills:
            driver.fill(t0, columns)
        code = self.engine.run(t0, rec, ext)
        self.t = t0 + n
        # one device lost: every device gets zero force in this block (its inputs, and so the
        # forces computed from them, are stale), before the run stops
        lost = next((d for d in self.drivers if getattr(d, "lost", None)), None)
        for driver, force, zeros in sends:
            driver.send(t0, zeros if lost is not None else force)
        if code:
            raise SafetyStop(*self.prog.guard.describe(code, t0, n))
        if lost is not None:
            raise SafetyStop(f"device {getattr(lost, 'name', '?')!r} stopped answering: {lost.lost}", 0)
        return rec


class Streamed:
    """What `stream` did: `samples` handed to the sink, `rate`, `compile_seconds`, `run_seconds`,
    and `stopped`: None, or the signal number whose request ended the run early."""

    def __init__(self, rate=0.0):
        self.samples, self.rate, self.stopped = 0, rate, None
        self.compile_seconds = self.run_seconds = 0.0


class ArraySink:
    """Keeps every block in arrays: the sink of `render`."""

    started = False

    def start(self, rate, channels, probes, total):
        self.started = True
        self.channels, self.probes, self.count = channels, list(probes), 0
        self.audio = np.zeros((total, channels))
        self.columns = np.zeros((len(self.probes), total))

    def write(self, block):
        n, k = block.shape[0], self.channels
        self.audio[self.count:self.count + n] = block[:, :k]
        self.columns[:, self.count:self.count + n] = block[:, k:].T
        self.count += n

    def result(self, streamed):
        upto = self.count
        probes = {label: self.columns[j, :upto] for j, label in enumerate(self.probes)}
        return Render(self.audio[:upto], probes, streamed.rate, streamed.compile_seconds, streamed.run_seconds)


def stream(patch, seconds, sink, probes=(), engine="compiled", chunk=1 << 14, progress=None, drivers=None,
           safety=False, runaway=1e3, stop=None):
    """Render `seconds` of a patch block by block into `sink`; returns a Streamed.

    `sink.start(rate, channels, probes, total)` comes first, then `sink.write(block)` for each
    block in order: a (n × channels + len(probes)) view, the audio then the probes, valid only
    during the call. A block with a NaN, an infinity or (with `safety`) a value over `runaway`
    sends zero force; with `safety` the run then stops with SafetyStop after handing the sink
    every sample before the one where it was caught. A lost device always stops it. `stop`, a
    StopRequest or any object with its two attributes (the command line's Interrupt), ends the
    run at the next block boundary once its `signum` is set; `stop.rendering` is set True when
    the first block is about to run (the kernel made). Any exception leaving here carries
    `.streamed`, the Streamed so far.
    """
    if engine == "python":
        chunk = min(chunk, 4096)
    out = Streamed(float(patch.rate))
    try:
        width = len(probes) + len(patch.devices) + sum(len(b.inputs) for b in patch.blocks.values()
                                                       if getattr(b.cls, "audio_sink", False))
        chunk = max(1, min(int(chunk), max(1024, (32 << 20) // (8 * max(1, width)))))   # rec ≤ ~32 MB
        session = Runner(patch, probes, drivers, engine, blocksize=chunk,
                          runaway=runaway if safety else np.inf)
        out.compile_seconds = session.engine.compile_seconds
        if stop is not None:
            stop.rendering = True
        _stream(session, seconds, sink, probes, progress, safety, stop, out)
    except BaseException as exc:
        exc.streamed = out
        raise
    return out


def _stream(session, seconds, sink, probes, progress, safety, stop, out):
    prog = session.prog
    total = int(round(seconds * prog.rate))
    width = prog.channels + len(probes)
    sink.start(prog.rate, prog.channels, probes, total)
    bar = progress_bar(total, f"rendering {prog.patch.name}", " samples", progress, unit_scale=True, leave=False)
    start = time.perf_counter()
    try:
        while out.samples < total:
            if stop is not None and stop.signum is not None:
                out.stopped = stop.signum
                break
            n = min(session.blocksize, total - out.samples)
            try:
                rec = session.process(n)
            except SafetyStop as exc:
                stopping = safety or any(getattr(d, "lost", False) for d in prog.drivers.values())
                keep = exc.kept if stopping else n
                if keep:
                    sink.write(session.rec[:keep, :width])
                    out.samples += keep
                    bar.update(keep)
                if stopping:
                    raise
                continue
            sink.write(rec[:, :width])
            out.samples += n
            bar.update(n)
    finally:
        out.run_seconds = time.perf_counter() - start
        bar.close()
        session.stop()


class StopRequest:
    """A stop asked for from a signal handler (`request` is one): the render ends at the next block
    boundary, keeping every block made. Asked before rendering began (while compiling), it raises
    KeyboardInterrupt at once: there is nothing yet to keep."""

    def __init__(self):
        self.signum, self.rendering = None, False

    def request(self, signum, frame=None):
        self.signum = signum
        if not self.rendering:
            raise KeyboardInterrupt


def render(patch, seconds, probes=(), engine="compiled", chunk=1 << 14, progress=None, drivers=None,
           safety=False, runaway=1e3):
    """Render `seconds` of a patch offline into arrays; returns a Render.

    `drivers` maps each device name of the patch to a Driver (hapticgraph.render supplies the
    simulated ones); the kernel runs in chunks, the drivers exchange inputs and forces between.
    A block with a NaN, an infinity or (with `safety`) a value over `runaway` in the audio or a
    force sends zero force. With `safety` the render then stops: SafetyStop is raised with
    `.result`, the Render of everything before the sample where it was caught. A lost device
    always stops it; KeyboardInterrupt likewise carries `.result`.
    """
    sink = ArraySink()
    try:
        streamed = stream(patch, seconds, sink, probes, engine, chunk, progress, drivers, safety, runaway)
    except (SafetyStop, KeyboardInterrupt) as exc:
        if sink.started:
            exc.result = sink.result(exc.streamed)
        raise
    return sink.result(streamed)


def __getattr__(name):
    # `Session` was this module's name for Runner until 0.1.0, beside the public hapticgraph.Session
    if name == "Session":
        warnings.warn("hapticgraph.graph.engine.Session is now hapticgraph.graph.engine.Runner; programs "
                      "use hapticgraph.Session", DeprecationWarning, stacklevel=2)
        return Runner
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
