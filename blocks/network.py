"""Fusing mass-spring blocks: every group of cells, lattices and springs that touch becomes one
structure-of-arrays network (positions, velocities, inverse masses, damping, CSR spring lists
with unsigned indices), so its size changes the arrays, never the generated code.

Also: cell references (`plate[3, 4]`), the half-step stability check and the stiffness and mass
matrices `hapticgraph modes` needs.
"""
import math
import re

import numpy as np

from .family import Array, Control, Family, Flag, Group, Number, Points, touching
from .laws import network_step_for
from . import points as pts
from .numbers import whole_number

_REF = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[([-0-9 ,.]*)\])?\s*")
IDX = np.uint32
EXACT_CELLS = 250_000   # networks up to this many cells are checked cell by cell, larger by a bound
CELL_PORTS = {"force": "input", "position": "output", "velocity": "output"}
MAX_CELLS = 20_000_000
BYTES_PER_CELL = 160   # an upper estimate of the fused arrays per cell (see benchmarks)
STABILITY_BOUND = 2.0


def stability_number(dt, stiffness_sum, mass, damping):
    """dt²·Σk/m + dt·γ/m: the half-step scheme needs it below STABILITY_BOUND."""
    return dt * dt * stiffness_sum / mass + dt * damping / mass



def index_problem(shape, index):
    if len(index) != len(shape):
        return f"index {list(index)} has {len(index)} coordinate(s); the lattice has shape {shape}"
    for i, (k, n) in enumerate(zip(index, shape)):
        if not 0 <= k < n:
            return f"index {list(index)} is out of range for shape {shape} (axis {i}: 0 … {n - 1})"
    return None




def is_mass_spring(inst):
    return getattr(inst.cls, "family", None) is MassSpring


def parse_ref(text):
    """'plate[3, 4]' -> ('plate', (3, 4)); 'bob' -> ('bob', None); None if unreadable."""
    m = _REF.fullmatch(text or "")
    if not m:
        return None
    if m.group(2) is None:
        return m.group(1), None
    try:
        return m.group(1), tuple(whole_number(v) for v in m.group(2).split(","))   # s[2.0] is s[2]
    except ValueError:
        return None


class Component:
    """One lattice or cell block inside a network: its cells' place in the flat arrays."""

    def __init__(self, index, inst, offset):
        self.index, self.inst, self.name, self.offset = index, inst, inst.name, offset
        v = inst.values
        if inst.cls.type_name == "lattice":
            self.shape = tuple(int(s) for s in v["shape"])
            full = math.prod(self.shape)
            alive = np.ones(full, dtype=bool)
            for idx in v["cut"]:
                alive[np.ravel_multi_index(tuple(idx), self.shape)] = False
            # int32 where it fits: this map lives as long as the network (4 bytes a cell)
            self.compact = np.full(full, -1, dtype=np.int32 if full < 2 ** 31 else np.int64)
            self.compact[alive] = np.arange(int(alive.sum()))
            self.alive = alive
            self.count = int(alive.sum())
        else:
            self.shape = ()
            self.compact = np.zeros(1, dtype=np.int64)
            self.alive = np.ones(1, dtype=bool)
            self.count = 1

    def flat(self, index):
        """The network-wide index of a cell (index None for a cell block), or None if cut."""
        if not self.shape:
            return self.offset
        k = self.compact[np.ravel_multi_index(tuple(index), self.shape)]
        return None if k < 0 else self.offset + int(k)

    def label(self, flat):
        if not self.shape:
            return self.name
        local = int(np.nonzero(self.compact == flat - self.offset)[0][0])
        return f"{self.name}[{', '.join(str(int(i)) for i in np.unravel_index(local, self.shape))}]"


class Network(Group):
    """The fused arrays of one group of touching mass-spring blocks (a family Group)."""

    def __init__(self, members, springs, rate, stencils=True):
        self.stencils = stencils    # False: always the CSR path (cells can be locked/cut live)
        self.dt = 1.0 / rate
        self.rate = rate
        self.components = []
        self.point_blocks = [m for m in members if pts.is_point_block(m)]
        offset = 0
        for inst in (m for m in members if not pts.is_point_block(m)):
            comp = Component(len(self.components), inst, offset)
            self.components.append(comp)
            offset += comp.count
        self.by_name = {c.name: c for c in self.components}
        self.springs = springs
        self.n = offset
        self.names = [m.name for m in members] + [s.name for s in springs]
        self.extra = pts.layout(offset, self.point_blocks, springs, [r for s in springs for r in _refs(s)])
        self._build()

    def _build(self):
        n = self.n
        self.pos = np.zeros(n + len(self.extra))
        self.vel = np.zeros(n + len(self.extra))
        self.frc = np.zeros(n)
        self.inv_m = np.ones(n)
        self.damp = np.zeros(n)      # per-cell damping added to the component's (overrides)
        self.anchor = np.zeros(n)
        self.cid = np.zeros(n, dtype=IDX)
        counts = np.zeros(n, dtype=np.int64)     # lattice springs per cell
        cols = []                                 # (component, its cells' neighbours, local indices)
        for comp in self.components:
            sl = slice(comp.offset, comp.offset + comp.count)
            self.cid[sl] = comp.index
            v = comp.inst.values
            if not comp.shape:
                if v["locked"]:
                    self.inv_m[sl] = 0.0
                continue
            counts[sl], c, self.anchor[sl] = _lattice_neighbours(comp, v["boundary"] == "fixed")
            cols.append((comp, c))
            for idx in v["lock"]:
                k = comp.flat(idx)
                if k is not None:
                    self.inv_m[k] = 0.0
            for o in v["cells"]:
                k = comp.flat(o["index"])
                if k is None:
                    continue
                if "mass" in o:
                    self.inv_m[k] = v["mass"] / o["mass"]
                if "damping" in o:
                    self.damp[k] = o["damping"] - v["damping"]
                if o.get("locked"):
                    self.inv_m[k] = 0.0
        # CSR straight from the per-lattice tables: components are contiguous and each table is
        # in row order already, so there is nothing to sort (and no list of pairs to hold)
        idx = IDX if n < 2 ** 32 else np.uint64
        self.rowptr = np.zeros(n + 1, dtype=idx)
        self.rowptr[1:] = np.cumsum(counts)
        self.col = np.empty(int(self.rowptr[-1]), dtype=idx)
        for comp, c in cols:
            start = int(self.rowptr[comp.offset])
            part = self.col[start:start + len(c)]
            part[:] = c
            part += comp.offset
        self.kr = np.ones(len(self.col))
        jr, jc, jk = [], [], []
        self._build_laws()
        for s in self.springs:
            if self.law(s) is not None:
                continue
            a, b = self.cell_of(s.values["a"]), self.cell_of(s.values["b"])
            jr += [a, b]
            jc += [b, a]
            jk += [s.values["tension"]] * 2
        self.jrow, self.jcol, self.jk = _csr(n, np.array(jr, dtype=np.int64), np.array(jc, dtype=np.int64),
                                             np.array(jk, dtype=np.float64))
        # the stencil fast path: one uniform lattice of 1, 2 or 3 dimensions, nothing irregular
        only = self.components[0] if len(self.components) == 1 else None
        self.scale = np.zeros((len(self.components), 3))   # per component: 1/mass, tension, damping
        self.inv_m0 = self.inv_m.copy()
        self.cut_cells = {}
        self.stencil = None
        self.drv = np.zeros(0, dtype=np.int64)    # the stencil's driven cells (wired), sorted
        if self.stencils and only is not None and only.shape and len(only.shape) <= 3 and not self.springs \
                and not self.extra:
            v = only.inst.values
            if not v["lock"] and not v["cut"] and not v["cells"]:
                self.stencil = ("string", "sheet", "cube")[len(only.shape) - 1]

    def law(self, link):
        """The Law of a link here: a linear spring to an extra point runs as a law (the CSR lists
        hold cells only)."""
        law = law_of(link)
        if law is None and any(self.cell_of(r) >= self.n for r in _refs(link)):
            from .laws import LinearLink
            return LinearLink
        return law

    def _build_laws(self):
        """Nonlinear links, law by law: their points (ia, ib), parameter rows, output slots (each
        link's force is kept in f[n + extra + j], read as `NAME.force`; a hammer's in its own
        slot), and per cell the Σ of their stiffest slopes and damping slopes and the stiffest
        link (for the stability check)."""
        self.laws, self.link_out = {}, {}
        self.nl_k, self.nl_g, self.nl_worst = np.zeros(self.n), np.zeros(self.n), {}
        first = self.n + len(self.extra)
        for s in self.springs:
            law = self.law(s)
            if law is None:
                continue
            ends = [self.cell_of(r) for r in _refs(s)]
            a, b = ends if len(ends) == 2 else (self.extra[s.name], ends[0])
            self.link_out[s.name] = a if pts.owns_point(s) else first + len(self.link_out)
            self.laws.setdefault(law, []).append((a, b, law.row(s.values, self.rate), self.link_out[s.name], s.name))
            slope, gamma = law.slope(s.values), law.damping_slope(s.values)
            for c in (a, b):
                if c >= self.n:
                    continue
                self.nl_k[c] += slope
                self.nl_g[c] += gamma
                if max(slope, gamma) > self.nl_worst.get(c, (-1.0,))[0]:
                    what = f"slope up to {slope:.4g} N/m" if slope >= gamma else f"damping up to {gamma:.4g} N·s/m"
                    self.nl_worst[c] = (max(slope, gamma), s.name, law.name, what)
        self.frc = np.zeros(first + len(self.link_out))
        self.law_arrays = {}
        for law, rows in self.laws.items():
            width = max(len(r[2]) for r in rows)
            prm = np.zeros((len(rows), max(width, 1)))
            for j, r in enumerate(rows):
                prm[j, :len(r[2])] = r[2]
            self.law_arrays.update({
                f"{law.name}_a": np.array([r[0] for r in rows], dtype=IDX),
                f"{law.name}_b": np.array([r[1] for r in rows], dtype=IDX),
                f"{law.name}_p": prm, f"{law.name}_o": np.array([r[3] for r in rows], dtype=IDX)})
        self.pt_slot = np.array([self.extra[p.name] for p in self.point_blocks], dtype=np.int64)
        self.pt_in = np.zeros((len(self.point_blocks), 2))

    def cell_of(self, ref):
        """The slot of a point reference: a cell, or an extra point (ground, a point block)."""
        if ref.strip() in self.extra:
            return self.extra[ref.strip()]
        name, index = parse_ref(ref)
        return self.by_name[name].flat(index)

    # -- the linear model `hapticgraph modes` reads -----------------------------------------
    def bodies(self):
        return [c.name for c in self.components]

    def links(self):
        return [s.name for s in self.springs]

    def notes(self, connections):
        """What the lossless linear modes leave out for this network."""
        notes = []
        for comp in self.components:
            driven = sorted({c.dst.port for c in connections
                             if c.dst.block == comp.name and c.dst.port in ("mass", "tension", "damping")})
            for port in driven:
                unit = {"mass": "kg", "tension": "N/m", "damping": "N·s/m"}[port]
                notes.append(f"{comp.name}.{port} is driven by a connection; its patch value "
                             f"{comp.inst.values[port]:g} {unit} is used")
        if np.any(self.dampings() > 0):
            notes.append("damping ignored (lossless modes)")
        return notes

    def shape_of(self, block, x):
        """A network-wide vector `x` seen on block's cells: an array of its shape (NaN where cut)."""
        comp = self.by_name[block]
        if not comp.shape:
            return np.array([x[comp.offset]])
        full = np.full(len(comp.compact), np.nan)
        alive = comp.compact >= 0
        full[alive] = x[comp.offset + comp.compact[alive]]
        return full.reshape(comp.shape)

    # -- the family Group protocol ------------------------------------------------------------
    @property
    def arrays(self):
        if self.stencil is not None:
            return {"x": self.pos, "v": self.vel, "f": self.frc, "drv": self.drv}
        extra = {"pt_slot": self.pt_slot, "pt_in": self.pt_in} if self.extra else {}
        return {"x": self.pos, "v": self.vel, "f": self.frc, "inv_m": self.inv_m, "damp": self.damp,
                "anchor": self.anchor, "cid": self.cid, "rowptr": self.rowptr, "col": self.col, "kr": self.kr,
                "jrow": self.jrow, "jcol": self.jcol, "jk": self.jk, "scale": self.scale, **extra, **self.law_arrays}

    def point(self, block, index):
        if block in self.link_out:
            return self.link_out[block] if index is None else None
        if block in self.extra and block != pts.GROUND:
            return self.extra[block] if index is None else None
        comp = self.by_name.get(block)
        if comp is None or (index is None) != (not comp.shape):
            return None
        if comp.shape and index_problem(list(comp.shape), list(index)):
            return None
        flat = comp.flat(index)
        return None if flat is None or self.cut_cells.get(flat) else flat

    def point_array(self, port):
        return {"position": "x", "velocity": "v", "force": "f"}[port]

    def controls(self):
        """The live mass (as its inverse), tension and damping of each component, per sample."""
        if self.stencil is not None:
            return []
        out = []
        for comp in self.components:
            out.append(("scale", (comp.index, 0), Control(comp.name, "mass", inverse=True)))
            if "tension" in comp.inst.cls.params:
                out.append(("scale", (comp.index, 1), Control(comp.name, "tension")))
            out.append(("scale", (comp.index, 2), Control(comp.name, "damping")))
        for j, p in enumerate(self.point_blocks):
            out.append(("pt_in", (j, 0), Control(p.name, "x")))
        for law, rows in self.laws.items():
            for j, row in enumerate(rows):
                out += [(f"{law.name}_p", (j, col), Control(row[4], param)) for col, param in law.controls]
        return out

    def step(self):
        from . import lattice
        dt = Number(self.dt, "float", "dt")
        if self.stencil is None:
            keys = ("x", "v", "f", "inv_m", "damp", "anchor", "cid", "rowptr", "col", "kr", "jrow", "jcol", "jk",
                    "scale")
            args = [Array(k) for k in keys] + [dt]
            if not self.laws and not self.extra:
                return lattice.network_step, args
            if self.extra:
                args += [Array("pt_slot"), Array("pt_in")]
            for law in self.laws:
                args += [Array(f"{law.name}_{k}") for k in "abpo"]
            return network_step_for(list(self.laws), points=bool(self.extra)), args
        comp = self.components[0]
        args = [Array("x"), Array("v"), Array("f"), Array("drv")]
        if len(comp.shape) > 1:                 # a sheet's rows and cols, a cube's planes, rows and cols
            names = ("planes", "rows", "cols")[-len(comp.shape):]
            args += [Number(extent, "int", name) for extent, name in zip(comp.shape, names)]
        args += [Control(comp.name, "mass", inverse=True), Control(comp.name, "tension"),
                 Control(comp.name, "damping"), dt, Flag(comp.inst.values["boundary"] == "fixed")]
        return getattr(lattice, f"{self.stencil}_step"), args

    def wired(self, points):
        """The stencil reads forces only at the cells wired into `f` (the CSR path reads all)."""
        self.drv = np.array(sorted(points.get("f", ())), dtype=np.int64)

    def views(self, block):
        if block not in self.by_name:
            return ()
        comp = self.by_name[block]
        cells = slice(comp.offset, comp.offset + comp.count)
        return self.pos[cells], self.vel[cells]

    def points(self, block):
        """A lattice's or a cell's cells as views of the network's arrays (Group.points)."""
        comp = self.by_name.get(block)
        if comp is None:
            raise ValueError(f"{block!r} is a link of a network; it has no cells")
        cells = slice(comp.offset, comp.offset + comp.count)
        whole = comp.count == len(comp.compact)
        shape = comp.shape if whole else (comp.count,)
        index = np.argwhere(comp.compact.reshape(comp.shape) >= 0) if comp.shape else np.zeros((1, 0), dtype=np.int64)

        def status():
            cut = np.zeros(comp.count, dtype=bool)
            for flat in self.cut_cells:
                if cells.start <= flat < cells.stop:
                    cut[flat - cells.start] = True
            locked = (self.inv_m[cells] == 0.0) & ~cut
            return locked.reshape(shape), cut.reshape(shape)
        return Points(self.pos[cells].reshape(shape), self.vel[cells].reshape(shape), self.frc[cells].reshape(shape),
                      comp.shape, index, status)

    def edit(self, block, index, action, apply=True):
        """Lock, unlock or cut a cell between kernel calls (the CSR path only); `apply=False`
        only checks."""
        if self.stencil is not None:
            raise ValueError(f"network {', '.join(self.names)} runs on a stencil; cells can only be edited in a "
                             "session started editable (play --console)")
        if action not in ("lock", "unlock", "cut"):
            raise ValueError(f"unknown cell edit {action!r} (lock, unlock, cut)")
        comp = self.by_name[block]
        if comp.shape:
            msg = index_problem(list(comp.shape), list(index or ()))
            if msg:
                raise ValueError(f"{block}: {msg}")
        flat = comp.flat(index)
        if flat is None or self.cut_cells.get(flat):
            raise ValueError(f"{block}{list(index or [])} is cut")
        if not apply:
            return flat
        if action == "lock":
            self.inv_m[flat] = 0.0
            self.vel[flat] = 0.0
        elif action == "unlock":
            self.inv_m[flat] = self.inv_m0[flat]
        elif action == "cut":
            # the cell leaves the network: no mass, no springs to it or from it, at rest at 0
            self.inv_m[flat] = 0.0
            self.pos[flat] = self.vel[flat] = 0.0
            self.anchor[flat] = 0.0
            for rowptr, col, k in ((self.rowptr, self.col, self.kr), (self.jrow, self.jcol, self.jk)):
                k[rowptr[flat]:rowptr[flat + 1]] = 0.0
                k[col == flat] = 0.0
            self.cut_cells[flat] = True
        else:
            raise ValueError(f"unknown cell edit {action!r} (lock, unlock, cut)")
        return flat

    def stiffness_parts(self, laws=False):
        """Per cell: (Σk of its lattice's springs and anchors, Σk of the joins on it; with `laws`
        also the stiffest slopes of its nonlinear links)."""
        t = np.array([c.inst.values["tension"] if c.shape else 0.0 for c in self.components])
        counts = np.diff(self.rowptr.astype(np.int64)) + self.anchor
        joins = np.add.reduceat(np.append(self.jk, 0.0), np.minimum(self.jrow[:-1], len(self.jk)).astype(np.int64))
        joins[np.diff(self.jrow.astype(np.int64)) == 0] = 0.0
        return t[self.cid] * counts, joins + self.nl_k if laws else joins

    def stiffness_sums(self):
        """Σk per cell (springs and anchors) at the components' current tensions."""
        own, joins = self.stiffness_parts()
        return own + joins

    def masses(self):
        m = np.array([c.inst.values["mass"] for c in self.components])[self.cid]
        with np.errstate(divide="ignore"):
            return np.where(self.inv_m > 0, m / self.inv_m, np.inf)

    def dampings(self):
        d = np.array([c.inst.values["damping"] for c in self.components])[self.cid]
        return d + self.damp

    def stiffness_matrix(self):
        """K (scipy sparse) with x'' = −M⁻¹K x, at the components' current tensions."""
        import scipy.sparse as sp
        n = self.n
        t = np.array([c.inst.values["tension"] if c.shape else 0.0 for c in self.components])
        rows = np.repeat(np.arange(n), np.diff(self.rowptr.astype(np.int64)))
        k_int = t[self.cid[rows]] * self.kr
        jrows = np.repeat(np.arange(n), np.diff(self.jrow.astype(np.int64)))
        off = sp.coo_matrix((np.concatenate([-k_int, -self.jk]),
                             (np.concatenate([rows, jrows]), np.concatenate([self.col, self.jcol]))), shape=(n, n))
        return (sp.diags(self.stiffness_sums()) + off).tocsr()

    def component_of(self, flat):
        return self.components[int(self.cid[flat])]


def _lattice_neighbours(comp, fixed):
    """A lattice's springs as CSR rows in local compact indices: per alive cell, the number of
    its neighbours and their indices (axis by axis, the lower one first), and its anchor count
    (edges of a fixed lattice). Built from one (cells × 2·dims) table of neighbours, cut ones
    marked −1, so no sorting and no list of pairs: its peak is a few tens of bytes a cell."""
    shape, alive, compact = comp.shape, comp.alive, comp.compact
    full = len(alive)
    strides = [int(np.prod(shape[i + 1:])) for i in range(len(shape))]
    table = np.full((full, 2 * len(shape)), -1, dtype=compact.dtype)
    anchors = np.zeros(full)
    flat = np.arange(full)
    k = 0
    for axis, n in enumerate(shape):
        coord = (flat // strides[axis]) % n
        for step in (-1, 1):
            inside = coord > 0 if step < 0 else coord < n - 1
            ok = alive & inside
            table[ok, k] = compact[flat[ok] + step * strides[axis]]
            if fixed:
                anchors += alive & ~inside
            k += 1
    table = table[alive]
    linked = table >= 0
    return linked.sum(axis=1), table[linked], anchors[alive]


def _csr(n, rows, cols, vals):
    order = np.argsort(rows, kind="stable")
    rowptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=rowptr[1:])
    idx = IDX if n < 2 ** 32 else np.uint64
    return rowptr.astype(idx), cols[order].astype(idx), np.ascontiguousarray(vals[order], dtype=np.float64)


def is_link(inst):
    """A link member (a spring, a contact, a plugin's link): it joins two points `a` and `b`."""
    return hasattr(inst.cls, "law_of")


def law_of(inst):
    """The Law of a link (None: the linear spring, on the CSR path)."""
    return inst.cls.law_of(inst.values)


def ends_of(inst):
    """The parameters naming the points a link joins (`a`, `b`; a hammer's `at`)."""
    return getattr(inst.cls, "ends", ("a", "b"))


def _refs(inst):
    return [inst.values[key] for key in ends_of(inst)]


def _joins(inst):
    if not is_link(inst):
        return ()
    refs = (parse_ref(r) for r in _refs(inst) if r.strip() != pts.GROUND)
    return [ref[0] for ref in refs if ref]


def group(blocks):
    """Mass-spring blocks grouped by touch: [(members, springs)] in patch order."""
    out = []
    for members in touching([b for b in blocks.values() if is_mass_spring(b)], _joins):
        bodies = [b for b in members if not is_link(b)]
        springs = [b for b in members if is_link(b)]
        if bodies or springs:
            out.append((bodies, springs))
    return out


def _cells(inst):
    return math.prod(int(n) for n in inst.values["shape"]) if inst.cls.type_name == "lattice" else 1


def check_cells(blocks, problems):
    """All lattices and cells of a patch together hold at most MAX_CELLS cells (each lattice is
    also capped on its own by its check); nothing sized by the cells is built here."""
    total, parts = 0, []
    for inst in sorted((b for b in blocks.values() if is_mass_spring(b) and not is_link(b)),
                       key=lambda b: b.index):
        n = _cells(inst)
        total += n
        parts.append(f"{inst.name}: {n:,}")
        if total > MAX_CELLS:
            shown = ", ".join(parts[:8]) + (", …" if len(parts) > 8 else "")
            problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): with it the patch has {total:,} "
                                    f"cells ({shown}), about {total * BYTES_PER_CELL / 1e9:.1f} GB; at most "
                                    f"{MAX_CELLS:,} cells are allowed in one patch, all lattices together")
            return


def _worst_exact(members, springs, rate):
    """The cell of a network farthest from stability, from its fused arrays:
    (number, component inst, label, m, Σk, γ, Σk of its lattice, Σk of its joins, component mass)."""
    net = Network(members, springs, rate)
    if net.n == 0:
        return None
    mass, damp = net.masses(), net.dampings() + net.nl_g
    movable = np.isfinite(mass)
    if not movable.any():
        return None
    own, joins = net.stiffness_parts(laws=True)
    ksum = own + joins
    number = np.where(movable, stability_number(net.dt, ksum, np.where(movable, mass, 1.0), damp), 0.0)
    worst = int(np.argmax(number))
    comp = net.component_of(worst)
    label = comp.label(worst)
    if worst in net.nl_worst:
        _, link, law, what = net.nl_worst[worst]
        label += f" (its stiffest link: {link!r}, law {law}, {what} in its declared range)"
    return (float(number[worst]), comp.inst, label, mass[worst], ksum[worst], damp[worst],
            own[worst], joins[worst])


def _worst_bound(members, springs, rate):
    """The same for a network too big to build at check time, from its declarations: every
    cell is given the most lattice springs a cell of its lattice can have (so the bound never
    passes an unstable network); cells with overrides or joins are taken one by one."""
    dt = 1.0 / rate
    joins, gammas = {}, {}
    for s in springs:
        for ref in _refs(s):
            name, index = parse_ref(ref)
            cell = (name, tuple(index) if index is not None else None)
            law = law_of(s)
            joins[cell] = joins.get(cell, 0.0) + (s.values["tension"] if law is None else law.slope(s.values))
            gammas[cell] = gammas.get(cell, 0.0) + (0.0 if law is None else law.damping_slope(s.values))
    best = None
    for inst in members:
        v = inst.values
        if pts.is_point_block(inst):
            continue
        if inst.cls.type_name == "lattice":
            shape = [int(n) for n in v["shape"]]
            fixed = v["boundary"] == "fixed"
            degree = sum(2 if fixed or n >= 3 else (1 if n == 2 else 0) for n in shape)
            own = v["tension"] * degree
            locked = {tuple(i) for i in v["lock"]} | {tuple(c["index"]) for c in v["cells"] if c.get("locked")}
            cut = {tuple(i) for i in v["cut"]}
            overrides = {tuple(c["index"]): c for c in v["cells"]}
            generic = tuple(1 if n >= 3 else 0 for n in shape)
            cells = {generic} | set(overrides) | {i for (n, i) in joins if n == inst.name}
        else:
            own, locked, cut, overrides = 0.0, {None} if v["locked"] else set(), set(), {}
            cells = {None}
        for index in cells:
            if index in locked or index in cut:
                continue
            o = overrides.get(index, {})
            m, g = o.get("mass", v["mass"]), o.get("damping", v["damping"]) + gammas.get((inst.name, index), 0.0)
            k_join = joins.get((inst.name, index), 0.0)
            number = stability_number(dt, own + k_join, m, g)
            if best is None or number > best[0]:
                label = inst.name if index is None else f"{inst.name}[{', '.join(map(str, index))}]"
                best = (number, inst, label, m, own + k_join, g, own, k_join)
    return best


def check_stability(blocks, rate, problems):
    """Refuse a network whose half-step update would blow up, naming the worst cell."""
    for members, springs in group(blocks):
        from .refs import check_own_masses
        check_own_masses(springs, rate, problems)
        if not any(not pts.is_point_block(m) for m in members):
            continue
        exact = sum(_cells(m) for m in members) <= EXACT_CELLS
        found = (_worst_exact if exact else _worst_bound)(members, springs, rate)
        if found is None or found[0] < STABILITY_BOUND:
            continue
        number, inst, label, m, k, g, k_own, k_join = found
        dt = 1.0 / rate
        # the largest stable value of the component's tension (or the smallest mass), others fixed
        hints = []
        budget = (STABILITY_BOUND - dt * g / m) * m / (dt * dt)   # the Σk the cell can take
        if inst.cls.type_name == "lattice" and inst.values["tension"] > 0 and k_own > 0:
            if budget > k_join:
                # only the lattice's own springs scale with its tension; the joins do not
                hints.append(f"largest stable tension {inst.values['tension'] * (budget - k_join) / k_own:.4g} N/m")
            else:
                hints.append("its joins alone are too stiff for it: lower their tension")
        mass_needed = (dt * dt * k + dt * g) / STABILITY_BOUND
        hints.append(f"smallest stable mass {mass_needed * inst.values['mass'] / m:.4g} kg")
        problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): unstable at {rate:g} Hz: cell "
                                f"{label} has dt²·Σk/m + dt·γ/m = {number:.3g}, the half-step "
                                f"scheme needs < {STABILITY_BOUND:g} ({'; '.join(hints)}; or raise the rate)")


class MassSpring(Family):
    """Cells, lattices and springs (Howard & Rimell 2003), fused group by group into a Network
    stepped by the half-step scheme: `network_step` (CSR) or a stencil for a uniform lattice."""

    point_ports = CELL_PORTS

    @classmethod
    def joins(cls, inst):
        return _joins(inst)

    @classmethod
    def link_ends(cls, inst):
        if not is_link(inst):
            return []
        return [(r.split("[")[0].strip(), r.strip()) for r in _refs(inst) if r.strip() != pts.GROUND]

    @classmethod
    def check(cls, blocks, problems, declared, rate):
        before = len(problems.problems)
        from .refs import check_springs
        resolved = check_springs(blocks, problems, declared)   # not when a link names a block in error
        check_cells(blocks, problems)      # before anything sized by the cells is built
        if resolved and len(problems.problems) == before:
            check_stability(blocks, rate, problems)

    @classmethod
    def point_problem(cls, inst, index, port, role):
        check_cell = getattr(inst.cls, "check_cell", None)
        if check_cell is None:
            return f"block {inst.name!r} ({inst.cls.type_name}) has no cells to index with {list(index)}"
        return check_cell(inst.values, index, port, role)

    @classmethod
    def build(cls, members, rate, editable=False):
        bodies = [b for b in members if not is_link(b)]
        springs = [b for b in members if is_link(b)]
        return Network(bodies, springs, rate, stencils=not editable) if bodies or springs else None
