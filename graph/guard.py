"""The guard: the safety check and the force clamp, one schedule item both engines run.

Per sample, after the records, it clamps each force sent to a device to the device's max_force
(`force_clamp`), unless that force is itself bad: not finite, or above the runaway limit (so a
faulty force is reported as it was). Nothing else happens per sample: after the sample loop, and
after the state is stored back, `kernel_guard` checks every recorded value of the call at once
(not finite, or — in the audio columns and the forces sent to devices, never in a probe — above
the runaway limit); only if one is bad does it look for the first (sample by sample, column by
column); else it finds the first state slot that is not finite. On a fault it zeroes every force
column of the call. The kernel returns its code: 0, 1 + sample·columns + column for a recorded
value, −1 − slot for a state slot; the value at fault is left in coef (the guard's report slot)
for the message. The earliest fault wins, whichever its kind.

Clamping a sound force never changes the verdict (a clamped value is no larger than the value),
and on a fault every force of the call is zeroed: so the forces a call returns are those of a
per-sample check that stops clamping at the first fault, for a fraction of its cost (issue 25,
item 4: benchmarks/overhead.py measures it).

The runaway limit and every max_force are data (coef slots), so changing them never recompiles.
"""
import math

from ..blocks.vocabulary import helper
from .identifiers import note

# what the check compares with when there is no runaway limit: every finite number passes
NO_LIMIT = 1.7976931348623157e308


@helper
def force_clamp(v, limit, top):
    """A force v clamped to ±top (its device's max_force), unless it is bad (not abs(v) <= limit)."""
    return min(max(v, -top), top) if abs(v) <= limit else v


@helper
def _all_sound(n, rec, limit, audio, forces):
    """Whether every rec[i, c] of the call passes (no early exit: the loop vectorises)."""
    sound = True
    for c in range(rec.shape[1]):
        bound = limit if (c < audio or c >= forces) else NO_LIMIT
        for i in range(n):
            sound &= abs(rec[i, c]) <= bound
    return sound


@helper
def _first_fault(n, rec, limit, audio, forces):
    """(1 + i·columns + c, rec[i, c]) for the first bad rec[i, c]; (0, 0.0) if none."""
    columns = rec.shape[1]
    for i in range(n):
        for c in range(columns):
            v = rec[i, c]
            bound = limit if (c < audio or c >= forces) else NO_LIMIT
            if not abs(v) <= bound:
                return 1 + i * columns + c, v
    return 0, 0.0


@helper
def kernel_guard(n, rec, state, coef, limit, audio, forces, report):
    """The end of a kernel call: its fault code, the value at fault in coef[report], and the force
    columns zeroed for the whole call on a fault."""
    code, value = 0, 0.0
    if not _all_sound(n, rec, limit, audio, forces):
        code, value = _first_fault(n, rec, limit, audio, forces)
    if code == 0:
        for k in range(state.shape[0]):
            if not abs(state[k]) <= NO_LIMIT:
                code, value = -1 - k, state[k]
                break
    if code != 0:
        coef[report] = value
        for j in range(n):
            for c in range(forces, rec.shape[1]):
                rec[j, c] = 0.0
    return code


def device_limit(driver):
    """A driver's max_force [N] (its attribute, else its block's internal value); inf if none."""
    bound = getattr(driver, "max_force", None)
    if bound is None:
        bound = driver.block_values().get("max_force")
    return math.inf if bound is None else float(bound)


class Guard:
    """The guard of a program (a schedule item, after the records): see the module's doc."""

    def __init__(self, prog):
        self.prog = prog
        self.columns = len(prog.records)
        self.audio = prog.channels
        self.forces = min((col for _, col in prog.device_records), default=self.columns)
        self.limit = prog.number(NO_LIMIT, "float", "guard", "limit")
        self.tops = [prog.number(device_limit(prog.drivers[device]), "float", "guard", "max_force")
                     for device, _ in prog.device_records]
        self.report = len(prog.numbers)     # where the kernel leaves the value at fault (not a local)
        prog.numbers.append(0.0)
        self.runaway = math.inf

    def set_runaway(self, runaway):
        """The runaway limit (inf: off); data, so the kernel is the same whatever it is."""
        self.runaway = float(runaway)
        self.prog.coef[self.limit.slot] = min(self.runaway, NO_LIMIT)

    # -- the schedule-item protocol ----------------------------------------------------------
    def functions(self):
        return [kernel_guard] + ([force_clamp] if self.tops else [])

    def emit_start(self, e):
        pass

    def emit(self, e):
        for c, top in enumerate(self.tops, self.forces):
            label = note(self.prog.records[c][0])
            e(f"rec[i, {c}] = force_clamp(rec[i, {c}], {self.limit.emit()}, {top.emit()})  # {label}: max_force")

    def emit_end(self, e):
        e(f"return kernel_guard(n, rec, state, coef, {self.limit.emit()}, {self.audio}, {self.forces}, {self.report})")

    def run(self, frame):
        limit = self.limit.value(frame)
        for c, top in enumerate(self.tops, self.forces):
            frame.rec_row[c] = force_clamp(frame.rec_row[c], limit, top.value(frame))

    def end(self, frame, rec):
        return kernel_guard(rec.shape[0], rec, frame.state, frame.coef, self.limit.value(frame), self.audio,
                            self.forces, self.report)

    # -- what a code means ---------------------------------------------------------------------
    def describe(self, code, t0, n):
        """(message, samples kept) for a kernel's fault code (≠ 0)."""
        prog = self.prog
        value = prog.coef[self.report]
        if code < 0:
            slot = -code - 1
            owner = [bp.name for bp in prog.plans for _ in bp.states]
            return f"numerical blow-up: the state of block {owner[slot] if slot < len(owner) else '?'!r} is {value}", n
        i, col = divmod(code - 1, self.columns)
        label, at = prog.records[col][0], (t0 + i) / prog.rate
        if not math.isfinite(value):
            return f"numerical blow-up: {label} is {value} at {at:.4f} s", i
        return f"runaway: {label} reached {abs(value):.3g} at {at:.4f} s, over the limit {self.runaway:g}", i
