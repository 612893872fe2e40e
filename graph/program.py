"""The runtime plan of a checked patch, shared by the compiler and the reference interpreter:
where every function argument of every block comes from, and the arrays that hold state,
live parameters, coefficients, buffers and recordings.

A binding is a node of the IR in ir.py (a literal, the sum of an input's connections, a live or
state slot, a cell's position, a device column, ...), which says its meaning for both engines.
"""
import numpy as np

from ..blocks.core import _arguments
from .ir import (ArrayItem, ArrayRef, BufferRef, Coef, Column, Counter, DerivedCoef, Inverse, Literal, Live,
                 Names, Output, StateSlot, Sum)
from .network import Network, group



class PlanError(Exception):
    pass


def _freeze(value):
    """Lists become tuples of floats (literals), numpy scalars become Python scalars."""
    if isinstance(value, np.ndarray):
        return tuple(float(x) for x in value.ravel())
    if isinstance(value, (list, tuple)):
        return tuple(float(x) for x in value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


class BlockPlan:
    """One block's part of the plan."""

    def __init__(self, index, inst):
        self.index, self.inst, self.cls, self.name = index, inst, inst.cls, inst.name
        self.values = dict(inst.values)
        self.inputs = {}          # public input name -> (source node, ...)
        self.live = {}            # live param -> slot
        self.live_sources = {}    # connected live param -> sources
        self.states = []          # slots
        self.state_nodes = []     # StateSlot of each state, named after the block
        self.live_nodes = {}      # live param -> Live
        self.coef_nodes = {}      # coefficient -> Coef
        self.ident = None         # the sanitized, unique prefix of the block's kernel locals
        self.buffers = []         # indices into Program.buffers
        self.coef_mode = None     # None | "literal" | "slot" | "per_sample"
        self.coefs = {}
        self.coef_slots = {}
        self.coef_arrays = {}     # array coefficients of a slot-mode block -> ArrayRef
        self.output_args = ()
        self.update_args = ()
        self.derive_args = {}     # for per-sample derive: param -> binding
        self.device = None        # the device entry this block is bound to
        self.ext = {}             # External attr -> column of the ext array

    def params(self):
        return self.cls.param_tuple()(**self.values)


class Program:
    """The plan of one patch: block plans in schedule order plus the runtime arrays."""

    def __init__(self, patch, probes=(), drivers=None, editable=False):
        self.patch, self.rate = patch, float(patch.rate)
        self.fs = self.rate
        self.plans = [BlockPlan(i, patch.blocks[name]) for i, name in enumerate(patch.order)]
        self.by_name = {bp.name: bp for bp in self.plans}
        self.drivers = dict(drivers or {})
        self.ext_columns = []     # (device, column name)
        for bp in self.plans:
            self._bind_device(bp)
        self.names = Names(_module_names(self.plans))
        for bp in self.plans:
            bp.ident = self.names.prefix(bp.index, bp.name)
        self.numbers, self.number_nodes, self._numbered = [], [], {}
        self.buffers, self.arrays = [], []
        self.buffer_nodes, self.array_nodes = [], []     # BufferRef / ArrayRef of each, named
        self.networks = [NetPlan(self, Network(members, springs, self.fs, stencils=not editable))
                         for members, springs in group(patch.blocks)]
        self.network_of = {name: net for net in self.networks for name in net.net.names}
        state, live = [], []
        coef = self.numbers       # the coef array: control-rate coefficients and every static number
        for bp in self.plans:
            self._connect(bp)
        for bp in self.plans:
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
            for b in cls.buffers:
                bp.buffers.append(len(self.buffers))
                self.buffer_nodes.append(BufferRef(len(self.buffers), self._local("buffer", bp, b.attr)))
                self.buffers.append(np.zeros(b.length(p, self.fs)))
            if cls.derive is not None:
                live_read = {n for n in cls.derive_reads if cls.params[n].live}
                # per sample when a connection drives a live parameter derive reads; else at
                # control rate, into coef slots (re-derived by set_param when it reads a live one)
                bp.coef_mode = "per_sample" if live_read & set(bp.live_sources) else "slot"
                bp.coefs = {k: _freeze(v) for k, v in cls.derive(p, self.fs).items()}
                if bp.coef_mode == "slot":
                    for k, v in bp.coefs.items():
                        if isinstance(v, tuple):   # an array coefficient: rewritten in place
                            bp.coef_arrays[k] = self._array(v, bp.ident, k)
                        elif isinstance(v, bool) and not live_read:
                            continue          # a flag fixed by the patch: structure (a literal)
                        else:
                            bp.coef_slots[k] = len(coef)
                            bp.coef_nodes[k] = Coef(len(coef), Coef.kind_of(v), self._local("coef", bp, k))
                            coef.append(float(v))
        for bp in self.plans:
            bp.output_args = self._bind(bp, bp.cls.output, "output")
            bp.update_args = self._bind(bp, bp.cls.update, "update")
            if bp.coef_mode == "per_sample":
                bp.derive_args = {n: self._param_binding(bp, n, per_sample=True) for n in bp.cls.params}
        self.state = np.array(state, dtype=np.float64)
        self.live = np.array(live, dtype=np.float64)
        self.records = []      # (label, binding)
        self.channels = 0
        for bp in self.plans:
            if getattr(bp.cls, "audio_sink", False):
                for port in bp.inst.inputs:
                    self.records.append((f"{bp.name}.{port.name}", Sum(bp.inputs.get(port.name, ()))))
                self.channels = len(bp.inst.inputs)
        for net in self.networks:
            net.bind()
        for probe in probes:
            self.records.append((probe, self.resolve_probe(probe)))
        self.device_records = []   # (device name, record column): the force each driver receives
        for bp in self.plans:
            if bp.device is not None:
                self.device_records.append((bp.device, len(self.records)))
                self.records.append((f"{bp.name}.force -> {bp.device}", Sum(bp.inputs.get("force", ()))))
        self.coef = np.array(self.numbers, dtype=np.float64)

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
        used = set(_arguments(cls.output) if cls.output else ()) | set(_arguments(cls.update) if cls.update else ())
        for e in cls.externals:
            if e.attr not in used:
                continue
            if e.attr not in columns:
                raise PlanError(f"driver of device {device!r} does not supply {e.attr!r} for block {bp.name!r}")
            bp.ext[e.attr] = offset + columns.index(e.attr)
        bp.ext_ports = {}
        for port in bp.inst.outputs:
            if getattr(port, "external", False):
                if port.name not in columns:
                    raise PlanError(f"driver of device {device!r} does not supply axis {port.name!r}")
                bp.ext_ports[port.attr] = offset + columns.index(port.name)
        self.ext_columns += [(device, c) for c in columns]

    # -- wiring --------------------------------------------------------------------------------
    def _source(self, end):
        """What a connection reads: a block output, or a cell's position/velocity array element."""
        net = self.network_of.get(end.block)
        if net is not None:
            return net.element(end)
        attr = self.patch.blocks[end.block].output(end.port).attr
        col = getattr(self.by_name[end.block], "ext_ports", {}).get(attr)
        if col is not None:
            return Column(col)
        return self.output(self.by_name[end.block], attr)

    def _local(self, kind, bp, attr):
        return self.names.local((kind, bp.index, attr), bp.ident, attr)

    def output(self, bp, attr):
        """The Output node of `attr` of block bp, named after the block (`loop_out`)."""
        return Output(bp.index, attr, self._local("out", bp, attr))

    def derived(self, bp):
        """The name of the coefficients block bp derives every sample, and of its parameter tuple."""
        return self._local("derived", bp, "coefs"), self._local("params", bp, "params")

    def _connect(self, bp):
        net = self.network_of.get(bp.name)
        for c in self.patch.connections:
            if c.dst.block != bp.name:
                continue
            source = self._source(c.src)
            if net is not None and c.dst.port == "force":
                net.add_force(c.dst, source)
            elif c.dst.port in bp.cls.params:
                bp.live_sources.setdefault(c.dst.port, []).append(source)
            else:
                bp.inputs.setdefault(c.dst.port, []).append(source)
        bp.inputs = {k: tuple(v) for k, v in bp.inputs.items()}
        bp.live_sources = {k: tuple(v) for k, v in bp.live_sources.items()}

    def _array(self, values, prefix, attr):
        """A kernel array argument, named `prefix_attr`; its ArrayRef."""
        node = ArrayRef(len(self.arrays), self.names.local(("array", len(self.arrays)), prefix, attr))
        self.arrays.append(np.asarray(values, dtype=np.float64))
        self.array_nodes.append(node)
        return node

    def number(self, value, kind, prefix, attr):
        """A number the kernel reads as data (coef[slot], loaded into the local `prefix_attr`
        before the sample loop), so that changing it re-uses the compiled kernel."""
        node = Coef(len(self.numbers), kind, self.names.local(("number", len(self.numbers)), prefix, attr))
        self.numbers.append(float(value))
        self.number_nodes.append(node)
        return node

    def _once(self, key, make):
        if key not in self._numbered:
            self._numbered[key] = make()
        return self._numbered[key]

    def _static(self, value, bp, attr):
        """A parameter that is not live: flags and choices are structure (literals in the source),
        numbers and tables are data (a coef slot, an array), so editing them re-uses the kernel."""
        value = _freeze(value)
        if isinstance(value, tuple):
            return self._array(value, bp.ident, attr)
        if isinstance(value, (bool, str)) or value is None:
            return Literal(value)
        return self.number(value, Coef.kind_of(value), bp.ident, attr)

    def _param_binding(self, bp, name, per_sample=False):
        param = bp.cls.params[name]
        if param.live:
            if name in bp.live_sources:
                return Sum(bp.live_sources[name])
            return bp.live_nodes[name]
        return self._static(bp.values[name], bp, name)

    def _bind(self, bp, fn, which):
        if fn is None:
            return ()
        cls = bp.cls
        ports_in = {p.attr: p.name for p in bp.inst.inputs}
        outs = {o.attr for o in cls.outputs}
        states = {s.attr: bp.state_nodes[i] for i, s in enumerate(cls.states)}
        buffers = {b.attr: bp.buffers[i] for i, b in enumerate(cls.buffers)}
        out = []
        for arg in _arguments(fn):
            if arg == "t":
                out.append(Counter())
            elif arg == "fs":
                out.append(self._once("fs", lambda: self.number(self.fs, "float", "sample", "rate")))
            elif arg in ports_in:
                out.append(Sum(bp.inputs.get(ports_in[arg], ())))
            elif arg in cls.params:
                out.append(self._param_binding(bp, arg))
            elif arg in states:
                out.append(states[arg])
            elif arg in buffers:
                out.append(self.buffer_nodes[buffers[arg]])
            elif arg.endswith("_mask") and arg[:-5] in buffers:
                # a ring's capacity (a power of two) is structure: its mask as a literal keeps a
                # register free in the sample loop (15 % on the waveguide benchmark); the delay
                # length inside it is data
                out.append(Literal(len(self.buffers[buffers[arg[:-5]]]) - 1))
            elif arg in bp.ext:
                out.append(Column(bp.ext[arg]))
            elif which == "update" and arg in outs:
                out.append(self.output(bp, arg))
            elif arg in bp.coefs:
                value = bp.coefs[arg]
                if bp.coef_mode == "per_sample":
                    out.append(DerivedCoef(bp.index, arg, self.derived(bp)[0]))
                elif arg in bp.coef_slots:
                    out.append(bp.coef_nodes[arg])
                elif arg in bp.coef_arrays:
                    out.append(bp.coef_arrays[arg])
                else:
                    out.append(self._static(value, bp, arg))
            else:
                raise PlanError(f"block {bp.name!r} ({cls.type_name}): {which}() argument {arg!r} "
                                "is bound to nothing")
        return tuple(out)

    # -- probes and control-rate changes ----------------------------------------------------------
    def resolve_probe(self, probe):
        """`BLOCK.PORT` (an output, an input, a live parameter or a state) or `LATTICE[i, j].PORT`
        (a cell's position, velocity, or force: the sum of the forces wired into it)."""
        from ..blocks.lattice import index_problem
        from .patch import Endpoint, _names, _suggest
        end = Endpoint.parse(probe)
        if end is None:
            raise PlanError(f"probe {probe!r}: {Endpoint.problem(probe)}")
        block, port = end.block, end.port
        bp = self.by_name.get(block)
        if bp is None:
            names = list(self.by_name)
            raise PlanError(f"probe {probe!r}: no block named {block!r}{_suggest(block, names)}; "
                            f"its blocks: {_names(names)}")
        net = self.network_of.get(block)
        comp = net.net.by_name.get(block) if net is not None else None
        cell_port = port in ("force", "position", "velocity") or end.index is not None
        if comp is not None and cell_port:
            cell = block if end.index is None else f"{block}[{', '.join(map(str, end.index))}]"
            if comp.shape and end.index is None:
                raise PlanError(f"probe {probe!r}: {block!r} is a lattice; address a cell as {block}[i, ...].{port}")
            if not comp.shape and end.index is not None:
                raise PlanError(f"probe {probe!r}: {block!r} is a single cell; write it without an index")
            ports = ("force", "position", "velocity")
            if port not in ports:
                raise PlanError(f"probe {probe!r}: a cell has no port {port!r}{_suggest(port, ports)}; "
                                "its ports: force (input), position, velocity (outputs)")
            msg = index_problem(list(comp.shape), list(end.index)) if comp.shape else None
            if msg:
                raise PlanError(f"probe {probe!r}: {msg}")
            flat = comp.flat(end.index)
            if flat is None:
                raise PlanError(f"probe {probe!r}: {cell} is cut out of its lattice; it has no ports")
            if port == "force":
                return Sum(tuple(net.forces.get(flat, ())))
            return Sum((net.element(end),))
        if end.index is not None:
            raise PlanError(f"probe {probe!r}: block {block!r} ({bp.cls.type_name}) has no cells to index")
        out = bp.inst.output(port)
        if out is not None:
            return Sum((self._source(Endpoint(block, None, port)),))
        for p in bp.inst.inputs:
            if p.name == port:
                return Sum(bp.inputs.get(port, ()))
        if port in bp.cls.params and bp.cls.params[port].live:
            return self._param_binding(bp, port)
        for i, s in enumerate(bp.cls.states):
            if s.attr == port:
                return bp.state_nodes[i]
        names = ([p.name for p in bp.inst.outputs + bp.inst.inputs] + [n for n, p in bp.cls.params.items() if p.live]
                 + [s.attr for s in bp.cls.states])
        raise PlanError(f"probe {probe!r}: block {block!r} ({bp.cls.type_name}) has no port or state "
                        f"{port!r}{_suggest(port, names)}; it has: {', '.join(dict.fromkeys(names)) or 'none'}")

    def edit_cell(self, block, index, action):
        """Lock, unlock or cut `block[index]` between kernel calls (needs `editable=True`)."""
        from .patch import Endpoint
        net = self.network_of.get(block)
        if net is None:
            raise PlanError(f"{block!r} is not a lattice or cell block")
        return net.edit(Endpoint(block, tuple(index) if index is not None else None, "position"), action)

    def set_param(self, block, name, value):
        """Change a live parameter between kernel calls (control rate): re-derives coefficients."""
        bp = self.by_name[block]
        param = bp.cls.params.get(name)
        if param is None or not param.live:
            raise PlanError(f"{block}.{name} is not a live parameter")
        if name in bp.live_sources:
            raise PlanError(f"{block}.{name} is driven by a connection")
        value = float(value)
        bp.values[name] = value
        self.live[bp.live[name]] = value
        if bp.coef_mode == "slot":
            for k, v in bp.cls.derive(bp.params(), self.fs).items():
                if k in bp.coef_slots:
                    self.coef[bp.coef_slots[k]] = float(v)
                elif k in bp.coef_arrays:
                    target = self.arrays[bp.coef_arrays[k].index]
                    if len(v) != len(target):
                        raise PlanError(f"{block}.{name}: its coefficient {k!r} changes length; that needs a recompile")
                    target[:] = v

    # -- the state a block carries (what a reload keeps) ------------------------------------------
    def state_views(self, block):
        """Writable numpy views of everything `block` remembers between samples, always in the
        same order: each State slot (a view of one element of the state array), each buffer, then
        for a cell or lattice block its cells' positions and velocities. Writing into a view changes
        what the next kernel call reads."""
        bp = self.by_name.get(block)
        if bp is None:
            raise PlanError(f"no block named {block!r}")
        views = [self.state[s:s + 1] for s in bp.states] + [self.buffers[b] for b in bp.buffers]
        net = self.network_of.get(block)
        if net is not None:
            views += net.cell_views(block)
        return tuple(views)

    def block_values(self, block):
        """The parameter values `block` plays with now: the patch's, with the changes set_param
        made between kernel calls (a copy)."""
        bp = self.by_name.get(block)
        if bp is None:
            raise PlanError(f"no block named {block!r}")
        return dict(bp.values)


_SHORT = {"pos": "x", "vel": "v", "frc": "f"}     # a network's arrays as a kernel names them: str_x, str_v


def _module_names(plans):
    """The names the kernel module defines: each block type's functions, the network steps."""
    names = {"network_step", "string_step", "sheet_step"}
    for bp in plans:
        t = bp.cls.type_name
        names |= {f"{t}_type", f"{t}_type_module", f"{t}_derive", f"{t}_output", f"{t}_update"}
    return names


class NetPlan:
    """A fused mass-spring network's part of the plan: its arrays (registered as kernel array
    arguments, updated in place), the forces wired into its cells, the live values of its
    components, and which step function advances it."""

    def __init__(self, prog, net):
        self.prog, self.net = prog, net
        names = ["pos", "vel", "frc", "inv_m", "damp", "anchor", "cid", "rowptr", "col", "kr",
                 "jrow", "jcol", "jk"]
        self.slots = {}
        self.prefix = prefix = prog.by_name[net.names[0]].ident
        self.points = {}          # flat cell index -> its number node
        self.scale = np.zeros((len(net.components), 3))
        for name in names + ["scale"]:
            self.slots[name] = len(prog.arrays)
            value = self.scale if name == "scale" else getattr(net, name)
            local = prog.names.local(("array", len(prog.arrays)), prefix, _SHORT.get(name, name))
            prog.arrays.append(value)
            prog.array_nodes.append(ArrayRef(self.slots[name], local))
        self.forces = {}          # flat index -> [sources]
        self.inv_m0 = net.inv_m.copy()
        self.cut_cells = {}
        self.scales = []          # (component, column, binding): the live scale of its cells

    def edit(self, end, action):
        net = self.net
        if net.stencil is not None:
            raise PlanError(f"network {', '.join(net.names)} runs on a stencil; start the session "
                            "editable to lock, unlock or cut cells")
        comp = net.by_name[end.block]
        if comp.shape:
            from ..blocks.lattice import index_problem
            msg = index_problem(list(comp.shape), list(end.index or ()))
            if msg:
                raise PlanError(f"{end.block}: {msg}")
        flat = comp.flat(end.index)
        if flat is None or self.cut_cells.get(flat):
            raise PlanError(f"{end.block}{list(end.index or [])} is cut")
        if action == "lock":
            net.inv_m[flat] = 0.0
            net.vel[flat] = 0.0
        elif action == "unlock":
            net.inv_m[flat] = self.inv_m0[flat]
        elif action == "cut":
            # the cell leaves the network: no mass, no springs to it or from it, at rest at 0
            net.inv_m[flat] = 0.0
            net.pos[flat] = net.vel[flat] = 0.0
            net.anchor[flat] = 0.0
            for rowptr, col, k in ((net.rowptr, net.col, net.kr), (net.jrow, net.jcol, net.jk)):
                k[rowptr[flat]:rowptr[flat + 1]] = 0.0
                k[col == flat] = 0.0
            self.cut_cells[flat] = True
        else:
            raise PlanError(f"unknown cell edit {action!r} (lock, unlock, cut)")
        return flat

    def array(self, name):
        """The ArrayRef of the network's array `name` (pos, vel, frc, ..., scale)."""
        return self.prog.array_nodes[self.slots[name]]

    def point(self, flat):
        """The index of cell `flat` as data: a number the kernel loads (`str_p0`, `str_p1`, ...)."""
        if flat not in self.points:
            self.points[flat] = self.prog.number(flat, "index", self.prefix, f"p{len(self.points)}")
        return self.points[flat]

    def element(self, end):
        comp = self.net.by_name[end.block]
        flat = comp.flat(end.index)
        node = self.prog.array_nodes[self.slots["pos" if end.port == "position" else "vel"]]
        return ArrayItem(node.index, self.point(flat), node.local)

    def add_force(self, end, source):
        flat = self.net.by_name[end.block].flat(end.index)
        self.point(flat)
        self.forces.setdefault(flat, []).append(source)

    def bind(self):
        """Bindings of the components' live mass, tension, damping (after live slots exist)."""
        for comp in self.net.components:
            bp = self.prog.by_name[comp.name]
            # the mass is read as its inverse: 1 / (the sum of what drives it)
            self.scales.append((comp.index, 0, Inverse(self.prog._param_binding(bp, "mass"))))
            if "tension" in bp.cls.params:
                self.scales.append((comp.index, 1, self.prog._param_binding(bp, "tension")))
            self.scales.append((comp.index, 2, self.prog._param_binding(bp, "damping")))
        self.step = self._step()

    def force_sums(self):
        """(index node of a driven cell, the sum of the forces wired into it)."""
        return [(self.points[flat], Sum(tuple(sources))) for flat, sources in self.forces.items()]

    def _step(self):
        """(function name, argument nodes) of the step; sizes and dt are numbers (data)."""
        net, prog = self.net, self.prog
        dt = prog.number(net.dt, "float", self.prefix, "dt")
        if net.stencil is not None:
            comp = net.components[0]
            fixed = comp.inst.values["boundary"] == "fixed"
            args = [self.array(k) for k in ("pos", "vel", "frc")]
            if net.stencil == "sheet":
                args += [prog.number(comp.shape[0], "int", self.prefix, "rows"),
                         prog.number(comp.shape[1], "int", self.prefix, "cols")]
            by_col = {col: b for _, col, b in self.scales}
            args += [by_col[0], by_col[1], by_col[2], dt, Literal(fixed)]
            return f"{net.stencil}_step", args
        args = [self.array(k) for k in ("pos", "vel", "frc", "inv_m", "damp", "anchor", "cid", "rowptr",
                                        "col", "kr", "jrow", "jcol", "jk", "scale")]
        return "network_step", args + [dt]

    def step_call(self):
        """(function name, argument bindings) of the step."""
        return self.step

    def cell_views(self, name):
        """(positions, velocities) of component `name`'s cells: writable views of the network's arrays."""
        comp = self.net.by_name[name]
        cells = slice(comp.offset, comp.offset + comp.count)
        return self.net.pos[cells], self.net.vel[cells]
