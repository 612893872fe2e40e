"""The guard: the safety check and the force clamp, one schedule item both engines run.

Per sample, after the records, it notes whether any recorded value is bad: not finite, or (in
the audio columns and the forces sent to devices, never in a probe) above the runaway limit, and
while none has been, clamps each force to its device's max_force (so the first faulty sample
keeps its values as they were). After the sample loop, and after the state is stored back,
`kernel_guard` finds the first bad value (sample by sample, column by column), or else the first
state slot that is not finite, and on a fault zeroes every force column of the call. The kernel
returns its code: 0, 1 + sample·columns + column for a recorded value, −1 − slot for a state
slot; the value at fault is left in coef (the guard's report slot) for the message. The earliest
fault wins, whichever its kind.

The check is made per sample, on values the kernel still holds in registers: checking rec once
after the loop instead reads the call's records back from memory, which cost more than it saved
(Fig. 7 in one 60 s call: 27 -> 34 ns a sample; benchmarks/overhead.py measures each item's share).

The runaway limit and every max_force are data (coef slots), so changing them never recompiles.
"""
import math

from ..blocks.vocabulary import helper

# what the check compares with when there is no runaway limit: every finite number passes
NO_LIMIT = 1.7976931348623157e308


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
def kernel_guard(n, bad, rec, state, coef, limit, audio, forces, report):
    """The end of a kernel call: its fault code, the value at fault in coef[report], and the force
    columns zeroed for the whole call on a fault."""
    code, value = 0, 0.0
    if bad:
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
        self.bad = prog.names.local(("guard", "bad"), "guard", "bad")
        self.report = len(prog.numbers)     # where the kernel leaves the value at fault (not a local)
        prog.numbers.append(0.0)
        self.runaway = math.inf

    def set_runaway(self, runaway):
        """The runaway limit (inf: off); data, so the kernel is the same whatever it is."""
        self.runaway = float(runaway)
        self.prog.coef[self.limit.slot] = min(self.runaway, NO_LIMIT)

    def _watched(self, c):
        return c < self.audio or c >= self.forces

    # -- the schedule-item protocol ----------------------------------------------------------
    def functions(self):
        return []

    def ends(self):
        return [kernel_guard]

    def emit_start(self, e):
        e(f"{self.bad} = False")

    def emit(self, e):
        for c in range(self.columns):
            bound = self.limit.emit() if self._watched(c) else "math.inf"
            test = "<=" if self._watched(c) else "<"
            e(f"{self.bad} |= not (abs(rec[i, {c}]) {test} {bound})")
        if self.tops:
            # clamped once the sample is known sound: the first faulty sample keeps its values
            e(f"if not {self.bad}:")
            e.indent()
            for c, top in enumerate(self.tops, self.forces):
                e(f"rec[i, {c}] = min(max(rec[i, {c}], -{top.emit()}), {top.emit()})")
            e.dedent()

    def emit_end(self, e, verdict):
        """The check after the loop, its code into the variable `verdict`."""
        e(f"{verdict} = kernel_guard(n, {self.bad}, rec, state, coef, {self.limit.emit()}, {self.audio}, "
          f"{self.forces}, {self.report})")

    def run(self, frame):
        limit = self.limit.value(frame)
        for c, v in enumerate(frame.rec_row):
            if not (abs(v) <= limit if self._watched(c) else abs(v) < math.inf):
                frame.bad = True
        if not frame.bad:
            for c, top in enumerate(self.tops, self.forces):
                top = top.value(frame)
                frame.rec_row[c] = min(max(frame.rec_row[c], -top), top)

    def end(self, frame, rec):
        return kernel_guard(rec.shape[0], frame.bad, rec, frame.state, frame.coef, self.limit.value(frame),
                            self.audio, self.forces, self.report)

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
