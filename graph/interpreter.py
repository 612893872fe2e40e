"""The reference interpreter: walks the program's schedule items (graph/items.py) sample by
sample in plain Python, calling every block's functions and every fused group's step as they are.
It shares the plan (which IR node feeds which argument, and what each node means: ir.py) with the
compiler but no generated code, so it is the specification the compiled kernel is tested against.
"""
from .denormals import FlushToZero
from .ir import Frame
from .program import Program


class Interpreter:
    key = None            # nothing is compiled: no kernel key (CompiledKernel.key)
    compiled = False

    def __init__(self, prog: Program):
        self.prog = prog
        self.compile_seconds = 0.0
        self.flush = FlushToZero()

    def run(self, t0, rec, ext):
        """Run rec.shape[0] samples from t0 with subnormals flushed to zero, as the kernel
        does (graph/denormals.py); the guard's code (0: sound; graph/guard.py)."""
        with self.flush:
            return self._run(t0, rec, ext)

    def _run(self, t0, rec, ext):
        p = self.prog
        frame = Frame(p.state, p.live, p.coef, p.buffers, p.arrays)
        for i in range(rec.shape[0]):
            frame.t, frame.ext_row, frame.rec_row = t0 + i, ext[i], rec[i]
            frame.outs, frame.derived = {}, {}
            for item in p.items:
                item.run(frame)
        for group in p.groups:
            group.end(frame, rec.shape[0])
        return p.guard.end(frame, rec)
