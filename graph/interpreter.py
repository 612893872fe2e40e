"""The reference interpreter: walks the scheduled graph and calls every block's functions from
plain Python, sample by sample. It shares the plan (which IR node feeds which argument, and what
each node means: ir.py) with the compiler but no generated code, so it is the specification the
compiled kernel is tested against.
"""
from .ir import Frame
from .program import Program


class Interpreter:
    def __init__(self, prog: Program):
        self.prog = prog
        self.compile_seconds = 0.0
        self._params = {bp.index: bp.cls.param_tuple() for bp in prog.plans}

    def run(self, t0, rec, ext):
        p = self.prog
        frame = Frame(p.state, p.live, p.coef, p.buffers, p.arrays)
        for i in range(rec.shape[0]):
            frame.t, frame.ext_row = t0 + i, ext[i]
            frame.outs, frame.derived = {}, {}
            for bp in p.plans:
                if bp.coef_mode == "per_sample":
                    args = [b.value(frame) for b in bp.derive_args.values()]
                    frame.derived[bp.index] = bp.cls.derive(self._params[bp.index](*args), p.fs)
                if bp.cls.output is None:
                    continue
                result = bp.cls.output(*[b.value(frame) for b in bp.output_args])
                if len(bp.cls.outputs) == 1:
                    result = (result,)
                for o, v in zip(bp.cls.outputs, result):
                    frame.outs[(bp.index, o.attr)] = v
            for k, (_, b) in enumerate(p.records):
                rec[i, k] = b.value(frame)
            new_states = []
            for bp in p.plans:
                if bp.cls.update is None:
                    continue
                result = bp.cls.update(*[b.value(frame) for b in bp.update_args])
                if bp.states:
                    if len(bp.states) == 1:
                        result = (result,)
                    new_states.extend(zip(bp.states, result))
            for slot, v in new_states:
                p.state[slot] = v
            for net in p.networks:
                self._step_network(net, frame)

    def _step_network(self, net, frame):
        from ..blocks import lattice
        p = self.prog
        frc = p.arrays[net.slots["frc"]]
        for point, force in net.force_sums():
            frc[point.value(frame)] += force.value(frame)
        if net.net.stencil is None:
            scale = p.arrays[net.slots["scale"]]
            for comp, col, b in net.scales:
                scale[comp, col] = b.value(frame)
        name, args = net.step_call()
        getattr(lattice, name)(*[a.value(frame) for a in args])
