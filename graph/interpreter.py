"""The reference interpreter: walks the scheduled graph and calls every block's functions from
plain Python, sample by sample. It shares the plan (which value feeds which argument) with the
compiler but no generated code, so it is the specification the compiled kernel is tested against.
"""
from .program import Program


class Interpreter:
    def __init__(self, prog: Program):
        self.prog = prog
        self.compile_seconds = 0.0
        self._params = {bp.index: bp.cls.param_tuple() for bp in prog.plans}

    def _value(self, b, bp, t, outs, derived, ext_row=None):
        kind = b[0]
        p = self.prog
        if kind == "t":
            return t
        if kind == "value":
            return b[1]
        if kind == "sum":
            if not b[1]:
                return 0.0
            total = None
            for src in b[1]:
                if src[0] == "@":
                    v = float(p.arrays[src[1]][src[2]])
                elif src[0] == "#":
                    v = float(ext_row[src[1]])
                else:
                    v = outs[src]
                total = v if total is None else total + v
            return total
        if kind == "inv":
            return 1.0 / self._value(b[1], bp, t, outs, derived, ext_row)
        if kind == "out":
            return outs[(b[1], b[2])]
        if kind == "own":
            return outs[(bp.name, b[1])]
        if kind == "live":
            return float(p.live[b[1]])
        if kind == "coef":
            v = float(p.coef[b[1]])
            return int(v) if b[2] == "int" else (v != 0.0 if b[2] == "bool" else v)
        if kind == "dcoef":
            return derived[bp.index][b[1]]
        if kind == "state":
            return float(p.state[b[1]])
        if kind == "buffer":
            return p.buffers[b[1]]
        if kind == "array":
            return p.arrays[b[1]]
        if kind == "mask":
            return b[1]
        if kind == "ext":
            return float(ext_row[b[1]])
        raise ValueError(f"unknown binding {b!r}")

    def run(self, t0, rec, ext):
        p = self.prog
        for i in range(rec.shape[0]):
            t = t0 + i
            outs, derived = {}, {}
            row = ext[i]

            def val(b, bp, t, outs, derived):
                return self._value(b, bp, t, outs, derived, row)
            for bp in p.plans:
                if bp.coef_mode == "per_sample":
                    args = [val(b, bp, t, outs, derived) for b in bp.derive_args.values()]
                    derived[bp.index] = bp.cls.derive(self._params[bp.index](*args), p.fs)
                if bp.cls.output is None:
                    continue
                result = bp.cls.output(*[val(b, bp, t, outs, derived) for b in bp.output_args])
                if len(bp.cls.outputs) == 1:
                    result = (result,)
                for o, v in zip(bp.cls.outputs, result):
                    outs[(bp.name, o.attr)] = v
            for k, (_, b) in enumerate(p.records):
                rec[i, k] = val(b, None, t, outs, derived)
            new_states = []
            for bp in p.plans:
                if bp.cls.update is None:
                    continue
                result = bp.cls.update(*[val(b, bp, t, outs, derived) for b in bp.update_args])
                if bp.states:
                    if len(bp.states) == 1:
                        result = (result,)
                    new_states.extend(zip(bp.states, result))
            for slot, v in new_states:
                p.state[slot] = v
            for net in p.networks:
                self._step_network(net, val, t, outs, derived)

    def _step_network(self, net, val, t, outs, derived):
        from ..blocks import lattice
        p = self.prog
        frc = p.arrays[net.slots["frc"]]
        for flat, sources in net.forces.items():
            frc[flat] += val(("sum", tuple(sources)), None, t, outs, derived)
        if net.net.stencil is None:
            scale = p.arrays[net.slots["scale"]]
            for comp, col, b, inv in net.scales:
                v = val(b, p.by_name[net.net.components[comp].name], t, outs, derived)
                scale[comp, col] = 1.0 / v if inv else v
        name, args = net.step_call()
        getattr(lattice, name)(*[val(a, None, t, outs, derived) for a in args])
