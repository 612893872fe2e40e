"""A fused mass-spring network: every group of cells, lattices, points and links that touch
becomes one Network, a family Group (blocks/family.py) over the arrays of arrays.py, stepped by
`network_step` (steps.py, CSR lists) with its links' laws (laws.py), or by a stencil
(stencils.py) for one uniform lattice. It is also a LinearGroup: the stiffness and mass matrices
`hapticgraph modes` reads, and the Σk the stability check reads.

A network is built once per load (`network_of`): the family's checks, `modes` and the first
Program to run it share it.
"""
import numpy as np

from ..family import Array, Change, Control, Flag, LinearGroup, Number, Points
from .arrays import IDX, cell_arrays, components, join_csr, lattice_csr
from .laws import LinearLaw, network_step_for
from .members import GROUND, index_problem, is_point_block, law_of, layout, owns_point, parse_ref, refs_of
from .stencils import cube_step, padded, padded_index, padded_zeros, sheet_step, string_step
from .steps import network_step, per_second, time_step

STENCILS = {"string": string_step, "sheet": sheet_step, "cube": cube_step}
# per-cell tables built on first use (Network.tables): a lattice on a stencil runs without them
TABLES = ("inv_m", "damp", "anchor", "cid", "rowptr", "col", "kr", "jrow", "jcol", "jk", "inv_m0", "nl_k", "nl_g")


def _table(key):
    return property(lambda self: self.tables()[key], doc=f"the per-cell table {key!r} (Network.tables)")


class Network(LinearGroup):
    """The fused arrays of one group of touching mass-spring blocks (a family Group)."""

    inv_m, damp, anchor, cid, rowptr, col, kr, jrow, jcol, jk, inv_m0, nl_k, nl_g = map(_table, TABLES)

    def __init__(self, members, springs, rate, stencils=True):
        self.dt = time_step(rate)
        self.rate = rate
        self.running = False        # a Program runs it (`wired`): the next to ask builds their own
        self.point_blocks = [m for m in members if is_point_block(m)]
        self.components = components([m for m in members if not is_point_block(m)])
        self.by_name = {c.name: c for c in self.components}
        self.springs = springs
        self.n = n = sum(c.count for c in self.components)
        self.names = [m.name for m in members] + [s.name for s in springs]
        self.extra = layout(n, self.point_blocks, springs, [r for s in springs for r in refs_of(s)])
        self._tables = None
        self._build_laws()
        self.scale = np.zeros((len(self.components), 3))   # per component: 1/mass, tension, damping
        self.cut_cells = {}
        self.drv = np.zeros(0, dtype=np.int64)    # the stencil's driven cells (wired), sorted
        self.use_stencils(stencils)

    def use_stencils(self, allowed):
        """Step on a stencil when `allowed` and the network is one uniform lattice of 1, 2 or 3
        dimensions with nothing irregular; else on the CSR lists (cells can then be locked and
        cut live). A stencil steps in one pass over the positions now (`pos`) and one sample
        before (`prev`), both with a ghost border (stencils.py), its velocities computed where
        read; the CSR lists keep the half-step's velocities (`vel`), which joins, locks and live
        edits act on. Either way the arrays start at rest, made here."""
        self.stencil = None
        self.vel = self.prev = None
        only = self.components[0] if len(self.components) == 1 else None
        if allowed and only is not None and only.shape and len(only.shape) <= 3 and not self.springs \
                and not self.extra:
            v = only.inst.values
            if not v["lock"] and not v["cut"] and not v["cells"]:
                self.stencil = ("string", "sheet", "cube")[len(only.shape) - 1]
        if self.stencil is None:
            points = self.n + len(self.extra)       # the cells, then the extra points, then link outputs
            self.pos, self.vel, self.frc = np.zeros(points), np.zeros(points), np.zeros(points + len(self.link_out))
        else:
            self.pos, self.prev, self.frc = (padded_zeros(only.shape) for _ in range(3))

    def tables(self):
        """The per-cell tables (TABLES), built on first use: inverse masses, damping, anchors and
        component ids (cell_arrays), the CSR lists of the lattices' springs and of the joins, the
        nonlinear links' slopes per cell. The CSR step runs on them; `modes`, the stability check
        of an irregular network and `points(...).locked` read them. A stencil runs without them,
        so a uniform lattice holds its positions twice and its forces: 24 bytes a cell."""
        if self._tables is None:
            t, n = {}, self.n
            t["inv_m"], t["damp"], t["anchor"], t["cid"], counts, cols = cell_arrays(self.components, n)
            t["rowptr"], t["col"] = lattice_csr(n, counts, cols)
            t["kr"] = np.ones(len(t["col"]))
            joins = [(self.cell_of(s.values["a"]), self.cell_of(s.values["b"]), s.values["tension"])
                     for s in self.springs if self.law(s) is None]
            t["jrow"], t["jcol"], t["jk"] = join_csr(n, joins)
            t["inv_m0"] = t["inv_m"].copy()
            t["nl_k"], t["nl_g"] = np.zeros(n), np.zeros(n)
            for c, slope, gamma in self.nl_slopes:
                t["nl_k"][c] += slope
                t["nl_g"][c] += gamma
            self._tables = t
        return self._tables

    @property
    def tables_built(self):
        """Whether the per-cell tables exist (a uniform lattice that only ran never builds them)."""
        return self._tables is not None

    def law(self, link):
        """The Law of a link here: a linear spring to an extra point runs as a law (the CSR lists
        hold cells only)."""
        law = law_of(link)
        if law is None and any(self.cell_of(r) >= self.n for r in refs_of(link)):
            return LinearLaw
        return law

    def _build_laws(self):
        """Nonlinear links, law by law: their points (ia, ib), parameter rows, output slots (each
        link's force is kept in f[n + extra + j], read as `NAME.force`; a hammer's in its own
        slot), and per cell the Σ of their stiffest slopes and damping slopes and the stiffest
        link (for the stability check)."""
        self.laws, self.link_out = {}, {}
        self.nl_slopes, self.nl_worst = [], {}
        first = self.n + len(self.extra)
        for s in self.springs:
            law = self.law(s)
            if law is None:
                continue
            ends = [self.cell_of(r) for r in refs_of(s)]
            a, b = ends if len(ends) == 2 else (self.extra[s.name], ends[0])
            self.link_out[s.name] = a if owns_point(s) else first + len(self.link_out)
            self.laws.setdefault(law, []).append((a, b, law.row(s.values, self.rate), self.link_out[s.name], s.name))
            slope, gamma = law.slope(s.values), law.damping_slope(s.values)
            for c in (a, b):
                if c >= self.n:
                    continue
                self.nl_slopes.append((c, slope, gamma))
                if max(slope, gamma) > self.nl_worst.get(c, (-1.0,))[0]:
                    what = f"slope up to {slope:.4g} N/m" if slope >= gamma else f"damping up to {gamma:.4g} N·s/m"
                    self.nl_worst[c] = (max(slope, gamma), s.name, law.name, what)
        self.law_arrays = {}
        for law, rows in self.laws.items():
            self.law_arrays.update(_law_arrays(law, rows))
        self.pt_slot = np.array([self.extra[p.name] for p in self.point_blocks], dtype=np.int64)
        self.pt_in = np.zeros((len(self.point_blocks), 2))

    def cell_of(self, ref):
        """The slot of a point reference: a cell, or an extra point (ground, a point block)."""
        if ref.strip() in self.extra:
            return self.extra[ref.strip()]
        name, index = parse_ref(ref)
        return self.by_name[name].flat(index)

    def component_of(self, flat):
        return self.components[int(self.cid[flat])]

    # -- the linear model (LinearGroup): `hapticgraph modes`, the stability check -------------
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

    # -- the family Group protocol ------------------------------------------------------------
    @property
    def arrays(self):
        if self.stencil is not None:
            return {"x": self.pos, "p": self.prev, "f": self.frc, "drv": self.drv}
        extra = {"pt_slot": self.pt_slot, "pt_in": self.pt_in} if self.extra else {}
        return {"x": self.pos, "v": self.vel, "f": self.frc, "inv_m": self.inv_m, "damp": self.damp,
                "anchor": self.anchor, "cid": self.cid, "rowptr": self.rowptr, "col": self.col, "kr": self.kr,
                "jrow": self.jrow, "jcol": self.jcol, "jk": self.jk, "scale": self.scale, **extra, **self.law_arrays}

    def point(self, block, index):
        if block in self.link_out:
            return self.link_out[block] if index is None else None
        if block in self.extra and block != GROUND:
            return self.extra[block] if index is None else None
        comp = self.by_name.get(block)
        if comp is None or (index is None) != (not comp.shape):
            return None
        if comp.shape and index_problem(list(comp.shape), list(index)):
            return None
        if self.stencil is not None:
            return padded_index(comp.shape, index)
        flat = comp.flat(index)
        return None if flat is None or self.cut_cells.get(flat) else flat

    def point_array(self, port):
        return {"position": "x", "velocity": "v", "force": "f"}[port]

    def reading(self, port):
        if port == "velocity" and self.stencil is not None:
            return Change("x", "p", per_second(self.rate), per_second)      # (x[n] − x[n−1]) · fs
        return self.point_array(port)

    def rotations(self):
        return [("x", "p")] if self.stencil is not None else []

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

    def rate_rows(self):
        """Each nonlinear link's row of its law's parameters (`Law.row`, which may read the rate)."""
        values = {s.name: s.values for s in self.springs}
        return [(f"{law.name}_p", j, law.row, (values[row[4]],)) for law, rows in self.laws.items()
                for j, row in enumerate(rows)]

    def step(self):
        dt = Number(self.dt, "float", "dt", time_step)
        if self.stencil is None:
            keys = ("x", "v", "f", "inv_m", "damp", "anchor", "cid", "rowptr", "col", "kr", "jrow", "jcol", "jk",
                    "scale")
            args = [Array(k) for k in keys] + [dt]
            if not self.laws and not self.extra:
                return network_step, args
            if self.extra:
                args += [Array("pt_slot"), Array("pt_in")]
            for law in self.laws:
                args += [Array(f"{law.name}_{k}") for k in "abpo"]
            return network_step_for(list(self.laws), points=bool(self.extra)), args
        comp = self.components[0]
        args = [Array("x"), Array("p"), Array("f"), Array("drv")]
        if len(comp.shape) > 1:                 # a sheet's rows and cols, a cube's planes, rows and cols
            names = ("planes", "rows", "cols")[-len(comp.shape):]
            args += [Number(extent, "int", name) for extent, name in zip(comp.shape, names)]
        args += [Control(comp.name, "mass", inverse=True), Control(comp.name, "tension"),
                 Control(comp.name, "damping"), dt, Flag(comp.inst.values["boundary"] == "fixed")]
        return STENCILS[self.stencil], args

    def wired(self, points):
        """The stencil reads forces only at the cells wired into `f` (the CSR path reads all).
        Only a Program tells this: from now on it runs the network."""
        self.running = True
        self.drv = np.array(sorted(points.get("f", ())), dtype=np.int64)

    def views(self, block):
        if block not in self.by_name:
            return ()
        if self.stencil is not None:
            return self._cells(self.pos), self._cells(self.prev)
        comp = self.by_name[block]
        cells = slice(comp.offset, comp.offset + comp.count)
        return self.pos[cells], self.vel[cells]

    def remembers(self, block):
        if block not in self.by_name:
            return ()
        return ("positions", "velocities" if self.stencil is None else "positions one sample before")

    def _cells(self, array):
        """A stencil's buffer seen as its lattice's cells: a view without the ghost border."""
        shape = self.components[0].shape
        return array.reshape(padded(shape))[tuple(slice(1, 1 + s) for s in shape)]

    def points(self, block):
        """A lattice's or a cell's cells as views of the network's arrays (Group.points)."""
        comp = self.by_name.get(block)
        if comp is None:
            raise ValueError(f"{block!r} is a link of a network; it has no cells")
        if self.stencil is not None:               # every cell, none locked or cut; velocities computed
            x, p, none = self._cells(self.pos), self._cells(self.prev), np.zeros(comp.shape, dtype=bool)
            return Points(x, (x - p) * self.rate, self._cells(self.frc), comp.shape,
                          np.argwhere(np.ones(comp.shape, dtype=bool)), lambda: (none, none.copy()), p)
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
        if apply:
            self._apply(flat, action)
        return flat

    def _apply(self, flat, action):
        if action == "lock":
            self.inv_m[flat] = 0.0
            self.vel[flat] = 0.0
        elif action == "unlock":
            self.inv_m[flat] = self.inv_m0[flat]
        else:
            # the cell leaves the network: no mass, no springs to it or from it, at rest at 0
            self.inv_m[flat] = 0.0
            self.pos[flat] = self.vel[flat] = 0.0
            self.anchor[flat] = 0.0
            for rowptr, col, k in ((self.rowptr, self.col, self.kr), (self.jrow, self.jcol, self.jk)):
                k[rowptr[flat]:rowptr[flat + 1]] = 0.0
                k[col == flat] = 0.0
            self.cut_cells[flat] = True


def _law_arrays(law, rows):
    """A law's arrays: its links' points a and b, parameter rows (padded) and output slots."""
    width = max(len(r[2]) for r in rows)
    prm = np.array([list(r[2]) + [0.0] * (max(width, 1) - len(r[2])) for r in rows], dtype=float)
    return {f"{law.name}_a": np.array([r[0] for r in rows], dtype=IDX),
            f"{law.name}_b": np.array([r[1] for r in rows], dtype=IDX),
            f"{law.name}_p": prm, f"{law.name}_o": np.array([r[3] for r in rows], dtype=IDX)}


def network_of(bodies, springs, rate):
    """The load's network of one group: built once, kept on the group's first member (`built`,
    blocks/family.py) and shared by the family's checks, `hapticgraph modes` and the first
    Program to run it. Once a Program runs it, the next to ask gets a network of their own."""
    members = bodies + springs
    first = min(members, key=lambda m: m.index)
    key = ("network", frozenset(m.name for m in members), rate)
    net = first.built.get(key)
    if net is None or net.running:
        net = first.built[key] = Network(bodies, springs, rate)
    return net
