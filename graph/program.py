"""The runtime plan of a checked patch, shared by the compiler and the reference interpreter:
where every function argument of every block comes from, and the arrays that hold state,
live parameters, coefficients, buffers and recordings.

A binding is a node of the IR in ir.py (a literal, the sum of an input's connections, a live or
state slot, a cell's position, a device column, ...), which says its meaning for both engines.
"""
import numpy as np

from ..blocks.vocabulary import arguments
from .blockplan import BlockPlan, freeze
from .codegen import module_names
from .errors import PlanError
from .family import GroupStep, groups
from .guard import Guard
from .identifiers import note
from .ir import (ArrayRef, BufferItem, BufferRef, Coef, Column, Counter, DerivedCoef, Literal, Live, Names, Output,
                 StateSlot, Total)
from .items import schedule_items
from .probes import resolve_probe

__all__ = ["PlanError", "Program"]


class Program:
    """The plan of one patch: block plans in schedule order, the fused groups, the runtime arrays,
    and `items`, the schedule both engines walk (graph/items.py)."""

    def __init__(self, patch, probes=(), drivers=None, editable=False):
        self.patch, self.rate = patch, float(patch.rate)
        self.fs = self.rate
        self.plans = [BlockPlan(i, patch.blocks[name]) for i, name in enumerate(patch.order)]
        self.by_name = {bp.name: bp for bp in self.plans}
        self.drivers = dict(drivers or {})
        self.ext_columns = []     # (device, column name)
        for bp in self.plans:
            self._bind_device(bp)
        built = [(family, family.build(members, self.fs, editable)) for family, members in groups(patch.blocks)]
        built = [(family, g) for family, g in built if g is not None]
        self.names = Names(module_names(self.plans, [g for _, g in built]))
        for bp in self.plans:
            bp.ident = self.names.prefix(bp.index, bp.name)
        self.numbers, self.number_nodes, self._numbered = [], [], {}
        self.buffers, self.arrays = [], []
        self.buffer_nodes, self.array_nodes = [], []     # BufferRef / ArrayRef of each, named
        self.groups = [GroupStep(self, family, g) for family, g in built]
        self.group_of = {name: gs for gs in self.groups for name in gs.group.names}
        for bp in self.plans:
            self._declare_buffers(bp)
        for bp in self.plans:
            self._connect(bp)
        state, live = [], []
        for bp in self.plans:
            self._declare(bp, state, live)
        for bp in self.plans:
            bp.output_args = self._bind(bp, bp.cls.output, "output")
            bp.update_args = self._bind(bp, bp.cls.update, "update")
            if bp.coef_mode == "per_sample":
                bp.derive_args = {n: self.param_binding(bp, n) for n in bp.cls.params}
        self.state = np.array(state, dtype=np.float64)
        self.live = np.array(live, dtype=np.float64)
        for gs in self.groups:
            gs.bind()
        self._records(probes)
        self.guard = Guard(self)     # after the records; its numbers go into coef
        self.coef = np.array(self.numbers, dtype=np.float64)
        self.items = schedule_items(self)

    def _declare_buffers(self, bp):
        """A block's buffers (before the wiring: an output may be an element of one, Out.element)."""
        for b in bp.cls.buffers:
            bp.buffers.append(len(self.buffers))
            self.buffer_nodes.append(BufferRef(len(self.buffers), self._local("buffer", bp, b.attr)))
            self.buffers.append(np.zeros(b.length(bp.params(), self.fs)))

    def _declare(self, bp, state, live):
        """Slots of a block's live parameters, states and control-rate coefficients."""
        cls, p = bp.cls, bp.params()
        for name, param in cls.params.items():
            if param.live and name not in bp.live_sources:
                bp.live[name] = len(live)
                bp.live_nodes[name] = Live(len(live), self._local("live", bp, name))
                live.append(float(bp.values[name]))
        for s in cls.states:
            bp.states.append(len(state))
            bp.state_nodes.append(StateSlot(len(state), self._local("state", bp, s.attr)))
            state.append(s.value(p, self.fs))
        if cls.derive is not None:
            self._declare_coefs(bp, p)

    def _declare_coefs(self, bp, p):
        live_read = {n for n in bp.cls.derive_reads if bp.cls.params[n].live}
        # per sample when a connection drives a live parameter derive reads; else at control rate,
        # into coef slots (re-derived by set_param when it reads a live one)
        bp.coef_mode = "per_sample" if live_read & set(bp.live_sources) else "slot"
        bp.coefs = {k: freeze(v) for k, v in bp.cls.derive(p, self.fs).items()}
        if bp.coef_mode != "slot":
            return
        for k, v in bp.coefs.items():
            if k in bp.cls.structure:
                # declared structure (a flag, a choice): a literal numba folds (graph/codegen.py
                # names it); set_param refuses to change it
                continue
            if isinstance(v, tuple):   # an array coefficient: rewritten in place
                bp.coef_arrays[k] = self.array(v, bp.ident, k)
            else:
                bp.coef_slots[k] = len(self.numbers)
                bp.coef_nodes[k] = Coef(len(self.numbers), Coef.kind_of(v), self._local("coef", bp, k))
                self.numbers.append(float(v))

    def _records(self, probes):
        """What the kernel records each sample: the audio channels, the probes, then the force each
        device receives (the inputs a block declares `sends`)."""
        self.records = []      # (label, binding)
        self.channels = 0
        for bp in self.plans:
            if getattr(bp.cls, "audio_sink", False):
                for port in bp.inst.inputs:
                    self.records.append((f"{bp.name}.{port.name}", Total(bp.inputs.get(port.name, ()))))
                self.channels = len(bp.inst.inputs)
        for probe in probes:
            self.records.append((probe, self.resolve_probe(probe)))
        self.device_records = []   # (device name, record column): the force each driver receives
        for bp in self.plans:
            if bp.device is None:
                continue
            for port in bp.inst.inputs:
                if getattr(port, "sends", False):
                    self.device_records.append((bp.device, len(self.records)))
                    self.records.append((f"{bp.name}.{port.name} -> {bp.device}", Total(bp.inputs.get(port.name, ()))))

    def _bind_device(self, bp):
        refs = [n for n, p in bp.cls.params.items() if p.refers == "devices"]
        if not refs:
            if not bp.cls.externals:
                return
            device = bp.name    # a block fed from outside by its own driver (e.g. audio_in)
        else:
            device = bp.values[refs[0]]
        driver = self.drivers.get(device)
        if driver is None:
            raise PlanError(f"block {bp.name!r}: no driver for device {device!r}")
        cls = driver.block_type or bp.cls
        if not issubclass(cls, bp.cls):
            raise PlanError(f"driver of device {device!r} offers {cls.__name__}, not a kind of {bp.cls.__name__}")
        values = {k: v for k, v in cls.default_params().items()}
        values.update({k: v for k, v in bp.values.items() if k in cls.params})
        values.update(driver.block_values())
        bp.cls, bp.values, bp.device = cls, values, device
        offset = len(self.ext_columns)
        columns = list(driver.columns)
        used = set(arguments(cls.output) if cls.output else ()) | set(arguments(cls.update) if cls.update else ())
        for e in cls.externals:
            if e.attr not in used:
                continue
            if e.attr not in columns:
                raise PlanError(f"driver of device {device!r} does not supply {e.attr!r} for block {bp.name!r}")
            bp.ext[e.attr] = offset + columns.index(e.attr)
        bp.ext_ports = {}
        # outputs the device's model computes itself (Out.element) rather than read from a column
        bp.elements = {p.attr: p.element for p in cls.ports(values)[1] if getattr(p, "element", None)}
        for port in bp.inst.outputs:
            if getattr(port, "external", False) and port.attr not in bp.elements:
                if port.name not in columns:
                    raise PlanError(f"driver of device {device!r} does not supply axis {port.name!r}")
                bp.ext_ports[port.attr] = offset + columns.index(port.name)
        self.ext_columns += [(device, c) for c in columns]

    # -- wiring --------------------------------------------------------------------------------
    def source(self, end):
        """What a connection reads: a block output, a device column, or a point of a fused group."""
        gs = self.group_of.get(end.block)
        if gs is not None:
            return gs.element(end)
        bp = self.by_name[end.block]
        attr = self.patch.blocks[end.block].output(end.port).attr
        col = getattr(bp, "ext_ports", {}).get(attr)
        if col is not None:
            return Column(col)
        if attr in bp.elements:
            return self._element(bp, *bp.elements[attr])
        return self.output(bp, attr)

    def _element(self, bp, buffer, index):
        """Element `index` of block bp's buffer `buffer`, which its output writes (Out.element)."""
        names = [b.attr for b in bp.cls.buffers]
        if buffer not in names:
            raise PlanError(f"block {bp.name!r} ({bp.cls.type_name}): an output is an element of "
                            f"{buffer!r}, which is not one of its buffers")
        node = self.buffer_nodes[bp.buffers[names.index(buffer)]]
        return BufferItem(node.index, int(index), node.local)

    def _local(self, kind, bp, attr):
        return self.names.local((kind, bp.index, attr), bp.ident, attr)

    def output(self, bp, attr):
        """The Output node of `attr` of block bp, named after the block (`loop_out`)."""
        return Output(bp.index, attr, self._local("output", bp, attr))

    def derived(self, bp):
        """The name of the coefficients block bp derives every sample, and of its parameter tuple."""
        return self._local("derived", bp, "coefs"), self._local("params", bp, "params")

    def _into_point(self, bp, port):
        gs = self.group_of.get(bp.name)
        return gs is not None and gs.family.point_ports.get(port) == "input"

    def _connect(self, bp):
        for c in self.patch.connections:
            if c.dst.block != bp.name:
                continue
            source = self.source(c.src)
            if self._into_point(bp, c.dst.port):
                self.group_of[bp.name].add_force(c.dst, source)
            elif c.dst.port in bp.cls.params:
                bp.live_sources.setdefault(c.dst.port, []).append(source)
            else:
                bp.inputs.setdefault(c.dst.port, []).append(source)
        bp.inputs = {k: tuple(v) for k, v in bp.inputs.items()}
        bp.live_sources = {k: tuple(v) for k, v in bp.live_sources.items()}

    # -- data: arrays and numbers ------------------------------------------------------------------
    def array(self, values, prefix, attr):
        """A kernel array argument, named `prefix_attr`, holding `values` (the same object when it
        is a float64 or integer numpy array: a family's arrays are updated in place); its ArrayRef."""
        node = ArrayRef(len(self.arrays), self.names.local(("array", len(self.arrays)), prefix, attr))
        self.arrays.append(values if isinstance(values, np.ndarray) else np.asarray(values, dtype=np.float64))
        self.array_nodes.append(node)
        return node

    def number(self, value, kind, prefix, attr):
        """A number the kernel reads as data (coef[slot], loaded into the local `prefix_attr`
        before the sample loop), so that changing it re-uses the compiled kernel."""
        node = Coef(len(self.numbers), kind, self.names.local(("number", len(self.numbers)), prefix, attr))
        self.numbers.append(float(value))
        self.number_nodes.append(node)
        return node

    def rate_node(self):
        """The sample rate, a number (data)."""
        if "fs" not in self._numbered:
            self._numbered["fs"] = self.number(self.fs, "float", "sample", "rate")
        return self._numbered["fs"]

    def _static(self, value, bp, attr):
        """A parameter that is not live: flags and choices are structure (literals in the source),
        numbers and tables are data (a coef slot, an array), so editing them re-uses the kernel."""
        value = freeze(value)
        if isinstance(value, tuple):
            return self.array(value, bp.ident, attr)
        if isinstance(value, (bool, str)) or value is None:
            return Literal(value, f"{note(bp.name)}: {attr}")
        return self.number(value, Coef.kind_of(value), bp.ident, attr)

    def param_binding(self, bp, name):
        """What parameter `name` of block bp reads: its live slot, the sum of the connections
        driving it, or its patch value (data or structure, see _static)."""
        param = bp.cls.params[name]
        if param.live:
            if name in bp.live_sources:
                return Total(bp.live_sources[name])
            return bp.live_nodes[name]
        key = ("static", bp.index, name)        # one array or slot, whichever functions read it
        if key not in self._numbered:
            self._numbered[key] = self._static(bp.values[name], bp, name)
        return self._numbered[key]

    def _bind(self, bp, fn, which):
        if fn is None:
            return ()
        return tuple(self._argument(bp, arg, which) for arg in arguments(fn))

    def _argument(self, bp, arg, which):
        """The IR node a block function's argument `arg` binds to."""
        cls = bp.cls
        ports_in = {p.attr: p.name for p in bp.inst.inputs}
        states = {s.attr: bp.state_nodes[i] for i, s in enumerate(cls.states)}
        buffers = {b.attr: bp.buffers[i] for i, b in enumerate(cls.buffers)}
        if arg == "t":
            return Counter()
        if arg == "fs":
            return self.rate_node()
        if arg in ports_in:
            return Total(bp.inputs.get(ports_in[arg], ()))
        if arg in cls.params:
            return self.param_binding(bp, arg)
        if arg in states:
            return states[arg]
        if arg in buffers:
            return self.buffer_nodes[buffers[arg]]
        if arg.endswith("_mask") and arg[:-5] in buffers:
            # a ring's capacity (a power of two) is structure: its mask as a literal keeps a
            # register free in the sample loop (15 % on the waveguide benchmark); the delay
            # length inside it is data
            return Literal(len(self.buffers[buffers[arg[:-5]]]) - 1, f"{note(bp.name)}: {arg[:-5]} ring mask")
        if arg in bp.ext:
            return Column(bp.ext[arg])
        if which == "update" and arg in {o.attr for o in cls.outputs}:
            return self.output(bp, arg)
        if arg in bp.coefs:
            if bp.coef_mode == "per_sample":
                return DerivedCoef(bp.index, arg, self.derived(bp)[0])
            if arg in bp.coef_slots:
                return bp.coef_nodes[arg]
            if arg in bp.coef_arrays:
                return bp.coef_arrays[arg]
            return Literal(bp.coefs[arg], f"{note(bp.name)}: {arg}")     # declared structure
        raise PlanError(f"block {bp.name!r} ({cls.type_name}): {which}() argument {arg!r} is bound to nothing")

    # -- probes and control-rate changes ----------------------------------------------------------
    def resolve_probe(self, probe):
        return resolve_probe(self, probe)

    def edit_cell(self, block, index, action, apply=True):
        """Lock, unlock or cut `block[index]` between kernel calls (needs `editable=True`);
        `apply=False` only checks (PlanError if refused)."""
        index = tuple(index) if index is not None else None
        return self._ask(block, lambda group: group.edit(block, index, action, apply))

    def _ask(self, block, question):
        """`question(group)` of the fused group of `block`; PlanError if it has none or refuses."""
        gs = self.group_of.get(self._plan(block).name)
        if gs is None:
            raise PlanError(f"{block!r} is not a lattice or cell block")
        try:
            return question(gs.group)
        except ValueError as exc:
            raise PlanError(str(exc)) from None

    def check_set(self, block, name, value):
        """PlanError if set_param(block, name, value) would be refused (nothing changes)."""
        bp = self._plan(block)
        param = bp.cls.params.get(name)
        if param is None or not param.live:
            raise PlanError(f"{block}.{name} is not a live parameter")
        if name in bp.live_sources:
            raise PlanError(f"{block}.{name} is driven by a connection")
        for bound, ok in ((param.minimum, lambda v, b: v >= b), (param.maximum, lambda v, b: v <= b),
                          (param.above, lambda v, b: v > b), (param.below, lambda v, b: v < b)):
            if bound is not None and not ok(value, bound):
                raise PlanError(f"{value:g} is outside the range of {block}.{name}")

    def set_param(self, block, name, value):
        """Change a live parameter between kernel calls (control rate): re-derives coefficients.
        PlanError, and nothing changed, if it would change the kernel's structure (a value its
        block declares `structure`, a table's length): that needs a recompile."""
        value = float(value)
        self.check_set(block, name, value)
        bp = self.by_name[block]
        derived = self._rederived(bp, name, value) if bp.coef_mode == "slot" else {}
        bp.values[name] = value
        self.live[bp.live[name]] = value
        for k, v in derived.items():
            if k in bp.coef_slots:
                self.coef[bp.coef_slots[k]] = float(v)
            elif k in bp.coef_arrays:
                self.arrays[bp.coef_arrays[k].index][:] = v

    def _rederived(self, bp, name, value):
        """What derive gives with `name` = value; PlanError if that changes the structure."""
        derived = bp.cls.derive(bp.params()._replace(**{name: value}), self.fs)
        for k, v in derived.items():
            if k in bp.cls.structure and freeze(v) != bp.coefs[k]:
                raise PlanError(f"{bp.name}.{name} = {value:g} changes {k!r}, part of the kernel's structure; "
                                "that needs a recompile")
            if k in bp.coef_arrays and len(v) != len(self.arrays[bp.coef_arrays[k].index]):
                raise PlanError(f"{bp.name}.{name}: its coefficient {k!r} changes length; that needs a recompile")
        return derived

    # -- the state a block carries (what a reload keeps) ------------------------------------------
    def state_views(self, block):
        """Writable numpy views of everything `block` remembers between samples, always in the
        same order: each State slot (a view of one element of the state array), each buffer, then
        what its fused group keeps for it (`remembers`). Writing into one changes the next call."""
        bp = self._plan(block)
        views = [self.state[s:s + 1] for s in bp.states] + [self.buffers[b] for b in bp.buffers]
        gs = self.group_of.get(block)
        if gs is not None:
            views += gs.group.views(block)
        return tuple(views)

    def remembers(self, block):
        """What the group's part of `state_views(block)` holds, by name (a reload matches them)."""
        gs = self.group_of.get(block)
        return tuple(gs.group.remembers(block)) if gs else ()

    def points(self, block):
        """The Points (blocks/family.py) of a lattice or cell block: numpy views of its cells."""
        return self._ask(block, lambda group: group.points(block))

    def block_values(self, block):
        """The parameter values `block` plays with now: the patch's, with the changes set_param
        made between kernel calls (a copy)."""
        return dict(self._plan(block).values)

    def _plan(self, block):
        bp = self.by_name.get(block)
        if bp is None:
            raise PlanError(f"no block named {block!r}")
        return bp
