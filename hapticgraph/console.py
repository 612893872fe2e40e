"""Edits while playing, typed on standard input (`hapticgraph play --console`):

    set BLOCK.PARAM VALUE      a live parameter (e.g. `set plate.mass 0.002`)
    lock NAME[i, j]            a cell stops moving        unlock NAME[i, j]   it moves again
    cut NAME[i, j]             a cell leaves its lattice, with its springs

Each command is checked here, then queued and applied by the audio thread at the next block
boundary, without a recompile. Mistakes are reported and change nothing.
"""
import re
import sys
import threading

from .graph.network import parse_ref
from .graph.program import PlanError

HELP = "commands: set BLOCK.PARAM VALUE | lock NAME[i, j] | unlock NAME[i, j] | cut NAME[i, j] | help"


def parse(line, prog):
    """(function, args, description) for one command line; ValueError with a message if wrong."""
    words = line.strip().split(None, 1)
    if not words:
        return None
    verb, rest = words[0].lower(), (words[1] if len(words) > 1 else "")
    if verb == "set":
        return _parse_set(rest, prog)
    if verb in ("lock", "unlock", "cut"):
        return _parse_edit(verb, rest, prog)
    if verb == "help":
        raise ValueError(HELP)
    raise ValueError(f"unknown command {verb!r}; {HELP}")


def _parse_set(rest, prog):
    """`set BLOCK.PARAM VALUE`: a live parameter no connection drives, within its range."""
    m = re.fullmatch(r"\s*([A-Za-z_]\w*)\.([A-Za-z_]\w*)\s*=?\s*(\S+)\s*", rest)
    if not m:
        raise ValueError("set BLOCK.PARAM VALUE")
    block, name, raw = m.groups()
    bp = prog.by_name.get(block)
    if bp is None:
        raise ValueError(f"no block named {block!r}")
    param = bp.cls.params.get(name)
    if param is None or not param.live:
        raise ValueError(f"{block}.{name} is not a live parameter")
    if name in bp.live_sources:
        raise ValueError(f"{block}.{name} is driven by a connection")
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"{raw!r} is not a number") from None
    for bound, ok in ((param.minimum, lambda v, b: v >= b), (param.maximum, lambda v, b: v <= b),
                      (param.above, lambda v, b: v > b), (param.below, lambda v, b: v < b)):
        if bound is not None and not ok(value, bound):
            raise ValueError(f"{value:g} is outside the range of {block}.{name}")
    return prog.set_param, (block, name, value), f"{block}.{name} = {value:g}"


def _parse_edit(verb, rest, prog):
    """`lock|unlock|cut NAME[i, j]`: a cell of a lattice or cell block that is not cut."""
    ref = parse_ref(rest)
    if ref is None:
        raise ValueError(f"{verb} NAME[i, j]")
    name, index = ref
    net = prog.network_of.get(name)
    if net is None:
        raise ValueError(f"{name!r} is not a lattice or cell block")
    if net.net.stencil is not None:
        raise ValueError("this patch plays on a stencil; cells can only be edited with --console from the start")
    comp = net.net.by_name[name]
    if comp.shape:
        from .blocks.lattice import index_problem
        problem = index_problem(list(comp.shape), list(index or ()))
        if problem:
            raise ValueError(problem)
    flat = comp.flat(index)
    if flat is None or net.cut_cells.get(flat):
        raise ValueError(f"{rest.strip()} is cut")
    return prog.edit_cell, (name, index, verb), f"{verb} {rest.strip()}"


class Console(threading.Thread):
    """Reads commands from `stream` and queues them on the session `current()` returns."""

    def __init__(self, current, stream=None, out=None):
        super().__init__(daemon=True, name="hapticgraph-console")
        self.current, self.stream, self.out = current, stream or sys.stdin, out or sys.stderr
        self.applied = []

    def submit(self, line):
        session = self.current()
        try:
            parsed = parse(line, session.prog)
        except ValueError as exc:
            print(f"hapticgraph: {exc}", file=self.out)
            return False
        if parsed is None:
            return False
        fn, args, text = parsed

        def apply():
            try:
                fn(*args)
                self.applied.append(text)
            except PlanError as exc:   # checked above; kept harmless should the patch have changed
                self.applied.append(f"refused: {exc}")
        session.edit(apply)
        print(f"hapticgraph: {text}", file=self.out)
        return True

    def run(self):
        for line in self.stream:
            self.submit(line)
