"""A patch lowered to C: the Program (graph/program.py) built with every device as columns of the
host (graph/c/drivers.py), its kernel translated (graph/c/kernel.py), each block's derive, check,
first states and ring sizes translated for the host's rate (graph/c/setup.py), and the API around
them (graph/c/api.py, graph/c/instance.py). What cannot be lowered is a PatchError: one
`FILE:LINE: message` per problem, naming the block and why."""
import inspect
import math
import os
from dataclasses import dataclass

from ...blocks.massspring import MassSpring
from ...blocks.vocabulary import Block, arguments
from .. import codegen
from ..errors import PatchError, PlanError, Problem
from ..identifiers import comment, ident
from ..program import Program
from ..schema import patch_schema
from . import api, instance
from .drivers import column_drivers, input_kind
from .kernel import KERNEL_FILE, translate_kernel
from .library import Library
from .runtime import PRELUDE
from .setup import check_function, constant, derive_function, rate_function, row_function, value_function
from .source import where
from .stability import stability_source
from .values import Refused, array_kind, literal


@dataclass
class Port:
    name: str
    input: bool
    kind: str
    unit: str


@dataclass
class Param:
    name: str
    unit: str
    low: float
    high: float
    default: float
    slot: int          # the live slot, −1 when it cannot be set while running
    bounds: tuple      # ((C operator, bound), ...): the range NAME_set checks


class CPlan:
    """Everything the C text says about one patch (see the module's doc)."""

    def __init__(self, patch, name, hosted=None):
        self.patch, self.name = patch, ident(name, "export name")
        self.title = comment(f"{self.name} ({patch.name})")
        self.prog = prog = Program(patch, (), column_drivers(patch))
        # the rate's slot, where a block function reads `fs` (the Program made it then: asking
        # for it makes nothing new)
        reads = any("fs" in arguments(f) for bp in prog.plans for f in (bp.cls.output, bp.cls.update) if f)
        self.rate_slot = prog.rate_node().slot if reads else None
        self.rate, self.live, self.coef, self.arrays = prog.rate, prog.live, prog.coef, prog.arrays
        rate = patch_schema(patch.registry)["properties"]["rate"]
        self.rates = (float(rate["minimum"]), float(rate["maximum"]))
        # a group of a family whose rate-dependent checks the export does not read keeps the patch's rate
        self.fixed_rate = next((f"a fused group of the {gs.family.__name__} family is built at the patch's rate"
                                for gs in prog.groups if gs.family is not MassSpring), None)
        self.flush_outside = not codegen.FLUSHES
        # columns the instance computes from NAME_midi's events (graph/c/drivers.Hosted), the rest from `in`
        self.hosted = hosted(patch, prog.ext_columns) if hosted is not None else None
        fed = self.hosted.columns if self.hosted is not None else frozenset()
        self.inputs = [Port(f"{device}.{column}", True, input_kind(patch, device), "")
                       for device, column in prog.ext_columns if (device, column) not in fed]
        self.ext_in = []            # each external column's index in `in`, None where the instance computes it
        for device, column in prog.ext_columns:
            self.ext_in.append(None if (device, column) in fed else sum(k is not None for k in self.ext_in))
        self.outputs = [Port(label, False, "audio", "") if c < prog.channels else
                        Port(label.partition(" -> ")[0], False, "cv", "N")
                        for c, (label, _) in enumerate(prog.records)]
        self.params = [p for bp in prog.plans for p in _params(bp)]
        self.lib = Library()
        self.checks, self.derives, self.state, self.buffers, self.setup = [], [], [], [], []
        self.rated, self.rows = [], []       # "slot = call" of the groups' numbers, "call" of their rows
        self.prefix = os.path.basename(str(patch.file)).replace("%", "%%")

    def lower(self):
        """This plan with its `header` and `source` (the C export); PatchError naming every block
        that cannot be lowered."""
        problems = [self._problem(bp, why) for bp in self.prog.plans for why in _structural(bp)]
        if problems:
            raise PatchError(problems)
        try:
            kernel, _ = translate_kernel(self.prog, self.lib, self._fixed_rings())
        except Refused as exc:
            raise PatchError([self._refused(exc)]) from None
        for bp in self.prog.plans:
            try:
                self._setup(bp)
            except Refused as exc:
                problems.append(self._refused(exc, bp))
        try:
            self._rates()
        except Refused as exc:
            problems.append(self._refused(exc))
        if problems:
            raise PatchError(problems)
        self.header, self.source = api.header(self), self._source(kernel)
        return self

    def _source(self, kernel):
        parts = [f"/* {self.title}: generated by hapticgraph export; do not edit. */",
                 f'#include "{self.name}.h"', PRELUDE]
        if self.hosted is not None:
            parts += [f"#define HG_CHUNK {api.CHUNK}       /* samples of hosted columns computed at a time */",
                      self.hosted.declarations]
        parts += [api.struct(self), api.tables(self)]
        parts += ["\n".join(self.lib.prototypes()) + "\n"] + self.lib.definitions() + [kernel] + self.setup
        parts += [api.setup_calls(self), instance.free(self), instance.reset(self), instance.refused(self),
                  instance.new(self), instance.process(self), instance.process_float(self),
                  instance.set_get(self), instance.midi(self)]
        return "\n".join(parts)

    def _fixed_rings(self):
        """Indices of the buffers whose size is the same at every rate: a ring's mask is then the
        literal numba is given (a register kept free in the sample loop, as numba keeps it)."""
        fixed, k = set(), 0
        for bp in self.prog.plans:
            for b in bp.cls.buffers:
                try:
                    size = constant(Library(), bp, b.size) if callable(b.size) else b.size
                except Refused:
                    size = None         # said where the size is translated for NAME_new
                if size is not None and len(self.prog.buffers[k]) == _capacity(size):
                    fixed.add(k)
                k += 1
        return frozenset(fixed)

    def _rates(self):
        """What the fused groups derive from the rate, translated: their numbers (Number.of_rate,
        Change.of_rate), their arrays' rows (Group.rate_rows), the stability check."""
        if self.fixed_rate:
            self.setup.append("static int hg_stability(double fs, hg_why *w) { (void)fs; (void)w; return 0; }\n")
            return
        for g, gs in enumerate(self.prog.groups):
            for k, (node, fn) in enumerate(gs.rated):
                name = f"hg_rated_{g}_{k}"
                self.setup.append(rate_function(self.lib, fn, name))
                self.rated.append(f"s->coef[{node.slot}] = {name}(rate);")
            for k, (ref, row, fn, args) in enumerate(gs.rate_rows):
                array = self.arrays[ref.index]
                if array_kind(array) != "arr2":
                    file, line = where(fn.__func__ if inspect.ismethod(fn) else fn)
                    raise Refused(file, line, f"a row computed from the rate, of {ref.local!r}, which is not a matrix "
                                              "of doubles")
                name = f"hg_row_{g}_{k}"
                self.setup.append(row_function(self.lib, fn, args, name))
                self.rows.append(f"{name}(s->rate, s->a{ref.index} + {int(row) * array.shape[1]});")
        self.setup.append(stability_source(self.lib, self.patch))

    def _setup(self, bp):
        cls, lib, tag = bp.cls, self.lib, ident(bp.ident, "block")
        check = cls.check.__func__
        if check is not Block.check.__func__:
            self.setup.append(check_function(lib, bp, check))
            self.checks.append((f"hg_check_{tag}", self._said(bp, "its check refuses %g Hz (hapticgraph check at "
                                                                  "that rate says why)")))
        if cls.derive is not None and bp.coef_mode == "slot":
            self.setup.append(derive_function(lib, bp))
            self.derives.append((f"hg_derive_{tag}", self._said(bp, "at %g Hz it derives a value the exported kernel "
                                                                    "holds as structure otherwise (export the patch "
                                                                    "at that rate)")))
        for s in cls.states:
            if callable(s.initial):
                self.setup.append(value_function(lib, bp, s.initial, f"hg_init_{tag}_{s.attr}", "f"))
                self.state.append(f"hg_init_{tag}_{s.attr}(s->live, s->rate)")
            else:
                self.state.append(literal(float(s.initial)))
        for b in cls.buffers:
            if callable(b.size):
                self.setup.append(value_function(lib, bp, b.size, f"hg_size_{tag}_{b.attr}", "i"))
                self.buffers.append(f"hg_size_{tag}_{b.attr}(s->live, rate)")
            else:
                self.buffers.append(literal(int(b.size)))

    def _said(self, bp, why):
        """A refusal of a rate by block bp, as a %-format of the rate (FILE:LINE: block ...: why)."""
        inst = self.patch.blocks[bp.name]
        return self.prefix + f":{inst.line}: block {bp.name!r} ({inst.cls.type_name}): ".replace("%", "%%") + why

    def _problem(self, bp, why):
        inst = self.patch.blocks[bp.name]
        return Problem(self.patch.file, inst.line, f"block {bp.name!r} ({inst.cls.type_name}) cannot be exported: {why}")

    def _refused(self, exc, bp=None):
        """A Refused translation as a problem at its Python FILE:LINE (at the first block's line in
        the patch when the Python has no file), naming the blocks concerned."""
        fns = set(exc.via[-1:])
        users = [b.name for b in self.prog.plans if bp is b or (fns and fns & {b.cls.output, b.cls.update, b.cls.derive})]
        users += [name for gs in self.prog.groups if gs.call[0] in fns for name in gs.group.names]
        kinds = [self.patch.blocks[u].cls.type_name for u in users]
        who = (f"block {users[0]!r} ({kinds[0]})" if len(users) == 1 else
               f"blocks {', '.join(f'{u!r} ({k})' for u, k in zip(users, kinds))}" if users else "the kernel")
        message = f"{who} cannot be exported to C: {exc.message}"
        if exc.file == KERNEL_FILE:
            message += " (in the generated kernel: a bug of the exporter)"
        if exc.file.startswith("<") and users:
            return Problem(self.patch.file, self.patch.blocks[users[0]].line, f"{message} ({exc.file})")
        return Problem(exc.file, exc.line, message)


def _capacity(size):
    """hg_capacity (graph/c/runtime.py): a ring's length for `size`, a power of two."""
    c, n = 1, max(1, int(size))
    while c < n:
        c <<= 1
    return c


def _structural(bp):
    """Why a block cannot be lowered at all yet (before anything is translated)."""
    if bp.coef_mode == "per_sample":
        driven = sorted(set(bp.live_sources) & set(bp.cls.derive_reads))
        yield f"a connection drives {', '.join(driven)}, which its derive reads every sample (not lowered yet)"


def _params(bp):
    for name, p in bp.cls.params.items():
        if p.kind != "number" or p.internal:
            continue
        bounds = tuple((op, float(b)) for op, b in ((">=", p.minimum), ("<=", p.maximum), (">", p.above),
                                                    ("<", p.below)) if b is not None)
        low = next((float(b) for b in (p.minimum, p.above) if b is not None), -math.inf)
        high = next((float(b) for b in (p.maximum, p.below) if b is not None), math.inf)
        yield Param(f"{bp.name}.{name}", p.unit, low, high, float(bp.values[name]), bp.live.get(name, -1), bounds)


def export_c(patch, name, hosted=None):
    """`patch` lowered to C99 under the prefix `name` (an identifier): a CPlan with `header`,
    `source`, its `inputs`, `outputs` (Port) and `params` (Param); PatchError for what cannot be.
    `hosted(patch, ext_columns)`, when given, says which device columns the instance computes from
    the events NAME_midi gives it (a graph/c/drivers.Hosted, or None)."""
    try:
        plan = CPlan(patch, name, hosted)
    except PlanError as exc:
        raise PatchError([Problem(patch.file, 1, f"cannot be exported: {exc}")]) from None
    return plan.lower()


__all__ = ["CPlan", "export_c"]
