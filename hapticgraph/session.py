"""The public door to a running patch (docs/api.md): open it with its devices' drivers (or
simulated ones), run it block by block, read any block and any lattice's cells, change it while it
runs, and swap in an edited version that keeps the state of every unchanged block.

    with hapticgraph.Session.open("patches/karplus_strong.yaml", probes=["loop.out"]) as s:
        block = s.process(64)                 # 64 × (audio channels + probes), a view
        s.set("loop", "gain", 0.9)            # applied at the next block boundary

A change (a parameter, a cell locked, unlocked or cut, a new patch) is checked when asked for
(ValueError saying what is wrong; nothing changes then), queued, and applied at the next block
boundary by whichever thread calls `process`: the sound card's callback in `hapticgraph play`,
the caller's loop elsewhere. `play`, `play --watch` and `play --console` use only this door.
"""
import collections
import os
import threading

import numpy as np

from .blocks.network import parse_ref
from .devices import Choice, open_drivers, parse_choice
from .devices.watch import carry_state, reload_drivers
from .graph.engine import Runner, SafetyStop, stop_driver
from .graph.patch import load
from .graph.errors import PlanError

CELL_EDITS = ("lock", "unlock", "cut")


class Swap:
    """An edited patch on its way in (Session.swap): `kept` names the blocks whose state carries
    over, `opened` the drivers opened for it (devices whose entry changed). It plays from the
    next block boundary on; `applied` is set then."""

    def __init__(self, session, runner, carry, kept, opened, unused):
        self.session, self.runner, self.carry = session, runner, carry
        self.kept, self.opened, self.unused = sorted(kept), opened, unused
        self.at = None              # the sample it began to play at
        self.applied = threading.Event()

    def wait(self, timeout=None):
        """Wait until it plays: True (the drivers it no longer uses are then stopped), or False
        after `timeout` seconds (withdrawn: the old patch keeps playing, nothing changed)."""
        if self.applied.wait(timeout) or not self.session.withdraw(self):
            self.applied.wait()
            self.session.retire()
            return True
        return False


class Session:
    """A patch running block by block (see the module's doc). Make one with `Session.open`."""

    def __init__(self, patch, drivers, probes=(), blocksize=64, engine="compiled", editable=True, runaway=1e3,
                 overrides=(), choices=None, live_input=None):
        self.overrides, self.choices, self.live_input = tuple(overrides), dict(choices or {}), live_input
        self.engine_name, self.editable, self.runaway = engine, editable, runaway
        self._runner = Runner(patch, probes, drivers, engine, blocksize=blocksize, runaway=runaway, editable=editable)
        self._edits, self._swaps, self._retired = collections.deque(), collections.deque(), collections.deque()
        self._cut = (0,)
        self._last = 0
        self.swaps = 0              # how many swaps were applied
        self.inputs = self.forces = None

    @classmethod
    def open(cls, patch, overrides=(), probes=(), devices=None, blocksize=64, engine="compiled", editable=True,
             drivers=None, live_input=None, runaway=1e3):
        """A Session of `patch` (a Patch, or a path loaded with `overrides`, "BLOCK.PARAM=VALUE").

        `probes`: what each block records besides the audio ("loop.out", "plate[4, 5].position");
        `devices`: {device name: "DRIVER[,KEY=VALUE...]" or a Choice} to use another driver than
        the patch's entry names ("simulated"); `drivers`: {name: Driver}, ready drivers instead
        (a replayed take); `live_input(block)`: the driver of an audio_in block with no file.
        `blocksize`: the most samples one `process` runs without copying; `engine`: "compiled"
        or "python" (the reference interpreter); `editable`: cells can be locked, unlocked and
        cut (lattices then run on their general path); `runaway`: a value over it in the audio
        or a force stops the run (SafetyStop). Raises PatchError, PlanError or DeviceError.
        """
        if isinstance(patch, (str, os.PathLike)):
            patch = load(patch, overrides=overrides)
        elif overrides:
            raise ValueError("overrides apply to a patch file; give its path")
        choices = device_choices(devices)
        opened = drivers is None
        if opened:
            drivers = open_drivers(patch, choices, live_input=live_input)
        try:
            return cls(patch, drivers, probes, blocksize, engine, editable, runaway, overrides, choices, live_input)
        except BaseException:
            for name, driver in drivers.items() if opened else ():
                stop_driver(name, driver)         # the devices opened for a session that never ran
            raise

    # -- facts -----------------------------------------------------------------------------------
    @property
    def rate(self):
        return self._runner.rate

    @property
    def t(self):
        """The samples processed so far (the time of the next one, in samples)."""
        return self._runner.t

    @property
    def blocksize(self):
        return self._runner.blocksize

    @property
    def program(self):
        """The plan underneath (graph.program.Program), for the devices layer (a take's header)."""
        return self._runner.prog

    @property
    def patch(self):
        return self._runner.prog.patch

    @property
    def kernel_key(self):
        """The compiled kernel's key (graph/cachekey.py): variants of one structure share it;
        None with the interpreter (engine="python")."""
        return self._runner.engine.key

    @property
    def compile_seconds(self):
        """Seconds spent making the running patch's kernel: compiled, or loaded from the cache."""
        return self._runner.engine.compile_seconds

    @property
    def compiled(self):
        """True when making this session's kernel compiled it (no cache entry, in this process or
        on disk, held it)."""
        return self._runner.engine.compiled

    @property
    def channels(self):
        return self._runner.prog.channels

    @property
    def probes(self):
        prog = self._runner.prog
        return tuple(label for label, _ in prog.records[prog.channels:self._first_force()])

    @property
    def drivers(self):
        """{device or block name: the Driver feeding it}."""
        return dict(self._runner.prog.drivers)

    def _first_force(self):
        prog = self._runner.prog
        return prog.device_records[0][1] if prog.device_records else len(prog.records)

    # -- running ---------------------------------------------------------------------------------
    def start(self):
        """Start the drivers (the first `process` does it otherwise)."""
        self._runner.start()

    def process(self, n):
        """Run the next n samples: a view (n × columns, the audio channels then the probes) valid
        until the next call; a fresh array when n exceeds the block size. After it, `inputs`
        and `forces` are views of what the drivers supplied and the forces sent to the devices.
        Raises SafetyStop (zero force was sent in that block) on a NaN, an infinity, a runaway
        or a lost device."""
        n = int(n)
        if n > self.blocksize:
            return self._long(n)
        if n < 1:
            raise ValueError(f"process({n}): expected a number of samples ≥ 1")
        if self._swaps or self._edits:
            self.apply()
        views = self._cut
        if views[0] != n:
            runner, f0 = self._runner, self._first_force()
            views = self._cut = (n, runner.rec[:n, :f0], runner.rec[:n, f0:], runner.ext[:n])
        _, out, self.forces, self.inputs = views
        self._last = 0
        self._runner.process(n)
        self._last = n
        return out

    def _long(self, n):
        out = np.empty((n, self._first_force()))
        done = 0
        while done < n:
            k = min(self.blocksize, n - done)
            out[done:done + k] = self.process(k)
            done += k
        return out

    def apply(self):
        """Apply what is queued (a swap, then the edits) now; `process` does it first."""
        while self._swaps:
            self._switch(self._swaps.popleft())
        while self._edits:
            self._edits.popleft()(self._runner.prog)

    def close(self):
        """Stop every driver (the session can be dropped then)."""
        for swap in tuple(self._swaps):
            self.withdraw(swap)
        self._runner.stop()
        self.retire()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"<hapticgraph.Session {self.patch.name!r} at {self.t} of {self.rate:g} Hz>"

    # -- reading ---------------------------------------------------------------------------------
    def audio_of(self, block):
        """The audio columns of a block `process` returned."""
        return block[:, :self.channels]

    def probes_of(self, block):
        """{probe: its column} of a block `process` returned."""
        return {label: block[:, self.channels + j] for j, label in enumerate(self.probes)}

    def values(self, block):
        """{name: value} of `block` now: each of its states, and each output a probe records
        (`BLOCK.PORT`), at the last sample processed."""
        prog = self._runner.prog
        cls = self._instance(block).cls
        out = {s.attr: float(v[0]) for s, v in zip(cls.states, prog.state_views(block))}
        if self._last:
            row = self._runner.rec[self._last - 1]
            for j, label in enumerate(self.probes):
                name, _, port = label.partition(".")
                if name == block:
                    out[port] = float(row[self.channels + j])
        return out

    def params(self, block):
        """{parameter: value} that `block` plays with now (the patch's, with the changes made)."""
        self._instance(block)
        return self._runner.prog.block_values(block)

    def points(self, block):
        """The cells of a lattice or cell block: Points with `positions`, `velocities`, `forces`
        (numpy views of the running state: writing into them moves the cells at the next block),
        `shape`, `cells`, and the masks `locked`, `cut`. Valid until a swap."""
        try:
            return self._runner.prog.points(block)
        except PlanError as exc:
            raise ValueError(str(exc)) from None

    def _instance(self, block):
        inst = self.patch.blocks.get(block)
        if inst is None:
            raise ValueError(f"no block named {block!r}; the blocks: {', '.join(self.patch.order)}")
        return inst

    # -- changing it -----------------------------------------------------------------------------
    def set(self, block, param, value, done=None):
        """Set a live parameter at the next block boundary; ValueError now if it cannot be.
        `done(text, error)` is called once applied (error: None, or why it was refused then)."""
        try:
            value = float(value)
            self._runner.prog.check_set(block, param, value)
        except (PlanError, TypeError) as exc:
            raise ValueError(str(exc)) from None
        self._queue(lambda prog: prog.set_param(block, param, value), f"{block}.{param} = {value:g}", done)

    def lock(self, cell, done=None):
        """The cell ("s[3]", "plate[4, 5]", or a cell block's name) stops moving."""
        self._cell("lock", cell, done)

    def unlock(self, cell, done=None):
        """The cell moves again."""
        self._cell("unlock", cell, done)

    def cut(self, cell, done=None):
        """The cell leaves its lattice, with its springs."""
        self._cell("cut", cell, done)

    def _cell(self, action, cell, done):
        ref = parse_ref(cell.strip()) if isinstance(cell, str) else None
        if ref is None:
            raise ValueError(f"{action} {cell!r}: write a cell as NAME[i, j] (or a cell block's NAME)")
        name, index = ref
        try:
            self._runner.prog.edit_cell(name, index, action, apply=False)
        except PlanError as exc:
            raise ValueError(str(exc)) from None
        self._queue(lambda prog: prog.edit_cell(name, index, action), f"{action} {cell.strip()}", done)

    def _queue(self, change, text, done):
        def edit(prog):
            try:
                change(prog)
                error = None
            except PlanError as exc:        # checked when asked; the patch may have been swapped since
                error = str(exc)
            if done is not None:
                done(text, error)
        self._edits.append(edit)

    @property
    def pending(self):
        """How many changes wait for the next block boundary."""
        return len(self._edits) + len(self._swaps)

    # -- swapping in an edited patch ----------------------------------------------------------------
    def swap(self, patch, devices=None, probes=None):
        """Compile `patch` (a Patch, or a path loaded with the session's overrides) now, and queue
        it for the next block boundary: the state of every block whose type, parameters and
        incoming connections did not change carries over, and the drivers of devices whose entry
        did not change keep running; `probes`, when given, replace the session's. Returns a Swap.
        Raises PatchError, PlanError, DeviceError, or ValueError for another sample rate (nothing
        changes then)."""
        for pending in tuple(self._swaps):
            self.withdraw(pending)
        self.retire()
        if isinstance(patch, (str, os.PathLike)):
            patch = load(patch, overrides=self.overrides)
        old = self._runner
        if float(patch.rate) != old.rate:
            raise ValueError(f"{patch.name!r} runs at {float(patch.rate):g} Hz, the session at {old.rate:g} Hz: "
                             "open a new session for another rate")
        choices = self.choices if devices is None else device_choices(devices)
        drivers, opened, unused = reload_drivers(old.prog.patch, patch, old.prog.drivers, choices, self.live_input)
        probes = self.probes if probes is None else tuple(probes)
        new = Runner(patch, probes, drivers, self.engine_name, blocksize=old.blocksize,
                     runaway=self.runaway, editable=self.editable)
        carry, kept = carry_state(old.prog, new.prog)
        if old.started:
            for driver in opened.values():
                driver.start(new.rate)
        swap = Swap(self, new, carry, kept, opened, unused)
        self._swaps.append(swap)
        return swap

    def withdraw(self, swap):
        """Take back a swap not yet applied (the drivers it opened stop, each within STOP_SECONDS:
        graph.engine.stop_driver, as `retire` and `close`); False if it already played."""
        try:
            self._swaps.remove(swap)
        except ValueError:
            return False
        for name, driver in swap.opened.items():
            stop_driver(name, driver)
        return True

    def retire(self):
        """Stop the drivers that applied swaps no longer use, each within its deadline
        (graph.engine.stop_driver; never from the audio thread)."""
        while self._retired:
            name, driver = self._retired.popleft()
            stop_driver(name, driver)

    def _switch(self, swap):
        old, new = self._runner, swap.runner
        for dst, src in swap.carry:
            np.copyto(dst, src)
        new.t = swap.at = old.t
        new.started = old.started
        self._runner = new
        self._cut = (0,)
        self._last = 0
        self._retired.extend(swap.unused)           # (name, driver) pairs
        self.swaps += 1
        swap.applied.set()


def device_choices(devices):
    """{device: Choice} of Session.open's `devices` ({name: "DRIVER[,KEY=VALUE...]" or a Choice})."""
    out = {}
    for name, spec in (devices or {}).items():
        if isinstance(spec, Choice):
            out[name] = spec
        elif isinstance(spec, str):
            out[name] = parse_choice(f"{name}={spec}")[1]
        else:
            raise ValueError(f"device {name!r}: expected a driver as text (\"simulated\", \"hid,profile=gamepad\") "
                             f"or a Choice, not {type(spec).__name__}")
    return out


__all__ = ["CELL_EDITS", "SafetyStop", "Session", "Swap", "device_choices"]
