"""The fused arrays of a mass-spring network (structure of arrays, one entry per cell): where
each body's cells sit (Component), their inverse masses, damping, anchors and component ids, the
lattices' springs as CSR lists with unsigned indices, and the joins (linear springs between
cells) as CSR lists of their own. Built with numpy from per-lattice tables, never from a list of
pairs, so a network's size changes the arrays, never the generated code.
"""
import math

import numpy as np

from .members import is_lattice

IDX = np.uint32


class Component:
    """One lattice or cell block inside a network: its cells' place in the flat arrays."""

    def __init__(self, index, inst, offset):
        self.index, self.inst, self.name, self.offset = index, inst, inst.name, offset
        v = inst.values
        if is_lattice(inst):
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

def components(bodies):
    """A Component for each body, their cells one after the other."""
    out, offset = [], 0
    for inst in bodies:
        comp = Component(len(out), inst, offset)
        out.append(comp)
        offset += comp.count
    return out


def cell_arrays(components, n):
    """Per cell of the network's n: (inverse mass relative to its component (0: locked), damping
    added to the component's (overrides), anchor springs (edges of a fixed lattice), component
    id), and per component its cells' lattice neighbours [(component, local indices)]."""
    inv_m = np.ones(n)
    damp = np.zeros(n)
    anchor = np.zeros(n)
    cid = np.zeros(n, dtype=IDX)
    counts = np.zeros(n, dtype=np.int64)     # lattice springs per cell
    cols = []                                 # (component, its cells' neighbours, local indices)
    for comp in components:
        sl = slice(comp.offset, comp.offset + comp.count)
        cid[sl] = comp.index
        v = comp.inst.values
        if not comp.shape:
            if v["locked"]:
                inv_m[sl] = 0.0
            continue
        counts[sl], c, anchor[sl] = _lattice_neighbours(comp, v["boundary"] == "fixed")
        cols.append((comp, c))
        _overrides(comp, v, inv_m, damp)
    return inv_m, damp, anchor, cid, counts, cols


def _overrides(comp, v, inv_m, damp):
    """A lattice's locked cells and per-cell overrides (mass, damping, locked)."""
    for idx in v["lock"]:
        k = comp.flat(idx)
        if k is not None:
            inv_m[k] = 0.0
    for o in v["cells"]:
        k = comp.flat(o["index"])
        if k is None:
            continue
        if "mass" in o:
            inv_m[k] = v["mass"] / o["mass"]
        if "damping" in o:
            damp[k] = o["damping"] - v["damping"]
        if o.get("locked"):
            inv_m[k] = 0.0


def lattice_csr(n, counts, cols):
    """(rowptr, col) of the lattices' springs: straight from the per-lattice tables, since
    components are contiguous and each table is in row order already, so there is nothing to
    sort (and no list of pairs to hold)."""
    idx = IDX if n < 2 ** 32 else np.uint64
    rowptr = np.zeros(n + 1, dtype=idx)
    rowptr[1:] = np.cumsum(counts)
    col = np.empty(int(rowptr[-1]), dtype=idx)
    for comp, c in cols:
        start = int(rowptr[comp.offset])
        part = col[start:start + len(c)]
        part[:] = c
        part += comp.offset
    return rowptr, col


def join_csr(n, joins):
    """(jrow, jcol, jk) of the joins [(cell a, cell b, tension)]: each spring in both rows."""
    jr, jc, jk = [], [], []
    for a, b, k in joins:
        jr += [a, b]
        jc += [b, a]
        jk += [k] * 2
    return _csr(n, np.array(jr, dtype=np.int64), np.array(jc, dtype=np.int64), np.array(jk, dtype=np.float64))


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
