"""Schedule items: everything the kernel does in one sample, in order, through one protocol.

Each item offers
  functions()   the Python functions it calls every sample (the kernel imports them and inlines
                them; the cache key hashes them)
  ends()        those it calls once, after the sample loop (imported and called, not inlined: a
                cold compile types and optimises them no more; hashed by the cache key too)
  emit(e)       its lines of the kernel's sample loop (e: a graph.codegen.Emitter)
  run(frame)    the same step in the reference interpreter (frame: graph.ir.Frame)
and the compiler and the interpreter loop over `Program.items` and nothing else: a block's
output (with its per-sample derive), a recorded value (audio, probe, the force a device
receives), the safety check of the records (graph.guard.Guard, which also emits the kernel's
start and end: `emit_start`, `emit_end`, and `end` for the interpreter), a block's update, a
fused family group's step (graph.family.GroupStep).
"""
from .codegen import emit_call
from .identifiers import ident, note
from .ir import Total


def _args(nodes):
    return ", ".join(node.emit() for node in nodes)


def _tname(bp):
    return ident(bp.cls.type_name, "block type name")


class BlockOutput:
    """A block's outputs this sample (after its coefficients, when they follow a signal)."""

    def __init__(self, prog, bp):
        self.prog, self.bp = prog, bp
        self.params = bp.cls.param_tuple() if bp.coef_mode == "per_sample" else None

    def functions(self):
        cls = self.bp.cls
        return ([cls.derive] if self.params is not None else []) + ([cls.output] if cls.output else [])

    def ends(self):
        return []

    def emit(self, e):
        bp, prog, tname = self.bp, self.prog, _tname(self.bp)
        e(f"# {note(bp.name, 30)} ({tname})")
        if self.params is not None:
            coefs, params = (ident(name, "derived coefficients") for name in prog.derived(bp))
            e(f"{coefs} = {tname}_derive({params}({_args(bp.derive_args.values())}), {prog.rate_node().emit()})")
        if bp.cls.output is not None:
            outs = [prog.output(bp, o.attr).emit() for o in bp.cls.outputs]
            emit_call(e, ", ".join(outs), f"{tname}_output", bp.output_args)

    def run(self, frame):
        bp = self.bp
        if self.params is not None:
            args = [b.value(frame) for b in bp.derive_args.values()]
            frame.derived[bp.index] = bp.cls.derive(self.params(*args), self.prog.rate_node().value(frame))
        if bp.cls.output is None:
            return
        result = bp.cls.output(*[b.value(frame) for b in bp.output_args])
        if len(bp.cls.outputs) == 1:
            result = (result,)
        for o, v in zip(bp.cls.outputs, result):
            frame.outs[(bp.index, o.attr)] = v


class Record:
    """One recorded value: rec[i, column] (an audio channel, a probe, a device's force)."""

    def __init__(self, column, label, binding):
        self.column, self.label, self.binding = column, label, binding

    def functions(self):
        return []

    def ends(self):
        return []

    def emit(self, e):
        e(f"rec[i, {int(self.column)}] = {self.binding.emit()}  # {note(self.label)}")

    def run(self, frame):
        frame.rec_row[self.column] = self.binding.value(frame)


class BlockUpdate:
    """A block's next state, once every output of the sample is known."""

    def __init__(self, prog, bp):
        self.prog, self.bp = prog, bp

    def functions(self):
        return [self.bp.cls.update]

    def ends(self):
        return []

    def emit(self, e):
        bp = self.bp
        emit_call(e, _args(bp.state_nodes) if bp.states else "", f"{_tname(bp)}_update", bp.update_args)

    def run(self, frame):
        bp = self.bp
        result = bp.cls.update(*[b.value(frame) for b in bp.update_args])
        if bp.states:
            if len(bp.states) == 1:
                result = (result,)
            for slot, v in zip(bp.states, result):
                frame.state[slot] = v


def schedule_items(prog):
    """The kernel's sample, in order: outputs in schedule order, records, the guard (graph/guard.py),
    updates, group steps."""
    items = [BlockOutput(prog, bp) for bp in prog.plans
             if bp.cls.output is not None or bp.coef_mode == "per_sample"]
    items += [Record(k, label, binding) for k, (label, binding) in enumerate(prog.records)]
    items.append(prog.guard)
    items += [BlockUpdate(prog, bp) for bp in prog.plans if bp.cls.update is not None]
    return items + list(prog.groups)


__all__ = ["BlockOutput", "BlockUpdate", "Record", "schedule_items"]
