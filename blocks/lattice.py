"""Mass-spring instruments (Howard & Rimell 2003, Cymatic): cells, n-dimensional lattices and springs.

These blocks declare; the graph layer fuses every group of touching cells, lattices and
springs into ONE structure-of-arrays network updated by `network_step` (CSR spring lists) or
`string_step` / `sheet_step` (stencils for regular 1-D and 2-D lattices), so a 100,000-cell
instrument is one loop and compiles as fast as a 10-cell one.

Integration is the half-step (leapfrog) scheme: velocities live half a sample ahead of positions,
    v[n+½] = v[n−½] + dt/m · (F_springs(x[n]) + F[n] − γ·v[n−½]),   x[n+1] = x[n] + dt·v[n+½],
stable while dt²·Σk/m + dt·γ/m < 2 for every cell (Gershgorin bound of the stiffness matrix).
A cell's `position` output is x[n], its `velocity` v[n−½]; its `force` input acts on v[n+½].
"""
import math

from .core import Block, In, Out, Param, helper
from .network import (BYTES_PER_CELL, CELL_PORTS, MAX_CELLS, STABILITY_BOUND, MassSpring,  # noqa: F401
                      index_problem, stability_number)

INDEX = {"type": "array", "items": {"type": "integer"}, "minItems": 1, "maxItems": 16}
INDICES = {"type": "array", "items": INDEX}
OVERRIDES = {"type": "array", "items": {
    "type": "object", "required": ["index"], "additionalProperties": False,
    "properties": {"index": INDEX,
                   "mass": {"type": "number", "exclusiveMinimum": 0, "description": "[kg]"},
                   "damping": {"type": "number", "minimum": 0, "description": "[N·s/m]"},
                   "locked": {"type": "boolean"}}}}
SHAPE = {"type": "array", "items": {"type": "integer"}, "minItems": 1, "maxItems": 16}
class Cell(Block, name="cell"):
    """m·(v[n+½] − v[n−½])/dt = F[n] + Σ springs − γ·v[n−½], x[n+1] = x[n] + dt·v[n+½].  Ref: Howard & Rimell 2003 (cells)."""

    force = In(doc="external force [N]")
    position = Out(doc="x[n] [m]")
    velocity = Out(doc="v[n−½] [m/s]")
    mass = Param(0.001, unit="kg", above=0.0, maximum=1e6)
    damping = Param(0.0, unit="N·s/m", minimum=0.0, maximum=1e6)
    locked = Param(False, doc="a locked cell never moves")
    family = MassSpring
    drawing = {"dot": "circle", "mermaid": ("((", "))")}


class Lattice(Block, name="lattice"):
    """Each cell: m·a = tension·Σ_neighbours(x_j − x_i) + F − damping·v (half-step); outside a fixed boundary x = 0.  Ref: Howard & Rimell 2003."""

    shape = Param([10], schema={**SHAPE, "description": "cells along each axis: [n] string, [n, m] sheet, ..."})
    mass = Param(0.001, unit="kg", above=0.0, maximum=1e6, doc="mass of each cell (scales the component)")
    tension = Param(100.0, unit="N/m", minimum=0.0, maximum=1e9, doc="stiffness of each neighbour spring")
    damping = Param(0.0, unit="N·s/m", minimum=0.0, maximum=1e6, doc="viscous damping of each cell")
    boundary = Param("fixed", choices=("fixed", "free"),
                     doc="fixed: cells on the edge are tied to 0 by one more spring; free: they are not")
    lock = Param([], schema={**INDICES, "description": "indices of cells that never move"})
    cut = Param([], schema={**INDICES, "description": "indices of cells removed from the lattice"})
    cells = Param([], schema={**OVERRIDES, "description": "per-cell mass, damping, locked"})
    family = MassSpring
    drawing = {"dot": "box3d", "mermaid": ("[[", "]]")}

    @classmethod
    def caption(cls, values):
        return "×".join(str(s) for s in values["shape"])

    @classmethod
    def check(cls, p, fs):
        shape = list(p.shape)
        bad = [s for s in shape if s < 1]
        if bad:
            yield "shape", f"every extent must be at least 1, got {shape}"
            return
        total = math.prod(shape)
        if total > MAX_CELLS:
            yield "shape", (f"{shape} is {total:,} cells, about {total * BYTES_PER_CELL / 1e9:.1f} GB; "
                            f"at most {MAX_CELLS:,} cells are allowed")
            return
        for key, items in (("lock", p.lock), ("cut", p.cut), ("cells", [c["index"] for c in p.cells])):
            for index in items:
                message = index_problem(shape, index)
                if message:
                    yield key, message

    @classmethod
    def check_cell(cls, values, index, port, role):
        """A problem with `name[index].port` used as an `role` ("input" or "output"; "probe": only
        read, so any port of a cell that is not cut), or None."""
        shape = list(values["shape"])
        message = index_problem(shape, list(index))
        if message:
            return message
        if port not in CELL_PORTS:
            return f"a cell has no port {port!r}; its ports: force (input), position, velocity (outputs)"
        if role != "probe" and CELL_PORTS[port] != role:
            return f"{port!r} is an {CELL_PORTS[port]}, it cannot be the {'source' if role == 'output' else 'destination'}"
        index = list(index)
        if index in [list(i) for i in values["cut"]]:
            return "this cell is cut out of the lattice; it has no ports"
        if role == "probe":
            return None
        locked = index in [list(i) for i in values["lock"]] or any(
            list(c["index"]) == index and c.get("locked") for c in values["cells"])
        if locked:
            return "this cell is locked (it never moves), so it cannot be wired"
        return None


class Spring(Block, name="spring"):
    """F = f(d) on cell a and −F on cell b, d = x_b − x_a: linear f = tension·d; cubic f = tension·d + k3·d³; table f = T(d) interpolated.  Ref: Howard & Rimell 2003 (joins); Faust mi.lib (nonlinear springs).

    `linear` stays on the CSR path of `network_step`; `cubic` and `table` are link laws
    (blocks/laws.py), explicit in the half-step scheme like the linear force. The stability check
    takes each law's stiffest slope over its declared range: tension + 3·k3·range² (cubic), the
    steepest segment of the table (table; outside `table_range` the force is held).
    """

    a = Param("", doc="a cell: a cell block's name or lattice[i, j]")
    b = Param("", doc="the other cell")
    tension = Param(100.0, unit="N/m", minimum=0.0, maximum=1e9, live=False)
    law = Param("linear", choices=("linear", "cubic", "table"), doc="force against extension d = x_b − x_a")
    k3 = Param(0.0, unit="N/m³", minimum=-1e18, maximum=1e18, live=False, doc="cubic: the d³ coefficient")
    range = Param(0.01, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="cubic: the largest |d| the stability check covers")
    table = Param([0.0, 0.0], doc="table: forces [N] at evenly spaced extensions over table_range", min_items=2,
                  max_items=4096)
    table_range = Param([-0.01, 0.01], unit="m", doc="table: [lowest, highest] extension", min_items=2,
                        max_items=2)
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @staticmethod
    def law_of(values):
        from . import laws
        return None if values["law"] == "linear" else laws.LAWS[values["law"]]

    @classmethod
    def check(cls, p, fs):
        if p.law == "table" and not p.table_range[1] > p.table_range[0]:
            yield "table_range", f"[lowest, highest] must rise, got {list(p.table_range)}"


class Contact(Block, name="contact"):
    """δ = gap − (x_b − x_a); F = k·δ^α + λ·δ^α·δ̇ (≥ 0) pushes a and b apart while δ > 0, else 0.  Ref: Hunt & Crossley 1975.

    A link of the mass-spring family (law `contact`, blocks/laws.py), explicit in the half-step
    scheme: F from x[n] and δ̇ from v[n−½]. The stability check takes k·α·range^(α−1), its
    stiffest slope up to a penetration `range`. `force` reads the force of the previous step.
    """

    a = Param("", doc="a cell: a cell block's name or lattice[i, j]")
    b = Param("", doc="the other cell (at rest at x_a + gap, above a)")
    gap = Param(0.0, unit="m", minimum=-1e3, maximum=1e3, live=False, doc="x_b − x_a at first touch")
    k = Param(1e4, unit="N/m^α", minimum=0.0, maximum=1e18, live=False, doc="stiffness")
    alpha = Param(1.0, minimum=1.0, maximum=10.0, live=False, doc="exponent α ≥ 1")
    damping = Param(0.0, unit="s/m", minimum=0.0, maximum=1e6, live=False, doc="Hunt–Crossley λ")
    range = Param(0.001, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="the largest penetration the stability check covers")
    force = Out(doc="F [N], ≥ 0 (one sample late: the force of the last step)")
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @staticmethod
    def law_of(values):
        from . import laws
        return laws.Contact


@helper
def network_step(pos, vel, frc, inv_m, damp, anchor, cid, rowptr, col, kr, jrow, jcol, jk, scale, dt):
    """One half-step of a fused network with CSR spring lists (unsigned indices).

    Per cell i of component c = cid[i]: scale[c] = (1/mass, tension, damping) at this sample;
    inv_m and anchor are relative to the component (0 inverse mass: locked), damp is added to the
    component's damping (per-cell overrides). Springs inside
    components (rowptr/col/kr, scaled by the tension) and joins (jrow/jcol/jk, absolute).
    """
    n = pos.shape[0]
    for i in range(n):
        c = cid[i]
        xi = pos[i]
        f = 0.0
        for e in range(rowptr[i], rowptr[i + 1]):
            f += kr[e] * (pos[col[e]] - xi)
        f = scale[c, 1] * (f - anchor[i] * xi)
        for e in range(jrow[i], jrow[i + 1]):
            f += jk[e] * (pos[jcol[e]] - xi)
        w = inv_m[i] * scale[c, 0]
        vel[i] += dt * w * (f + frc[i] - (scale[c, 2] + damp[i]) * vel[i])
        frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def string_step(pos, vel, frc, inv_mass, tension, damping, dt, fixed):
    """The 1-D stencil of a uniform lattice (no locks, cuts, overrides or joins)."""
    n = pos.shape[0]
    w = dt * inv_mass
    end = tension if fixed else 0.0
    if n == 1:
        vel[0] += w * (frc[0] - 2.0 * end * pos[0] - damping * vel[0])
        frc[0] = 0.0
    else:
        vel[0] += w * (tension * (pos[1] - pos[0]) - end * pos[0] + frc[0] - damping * vel[0])
        frc[0] = 0.0
        for i in range(1, n - 1):
            vel[i] += w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) + frc[i] - damping * vel[i])
            frc[i] = 0.0
        vel[n - 1] += w * (tension * (pos[n - 2] - pos[n - 1]) - end * pos[n - 1] + frc[n - 1]
                           - damping * vel[n - 1])
        frc[n - 1] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def _sheet_cell(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed):
    """One cell of a sheet with every boundary test (the edge rows and columns)."""
    i = r * cols + c
    xi = pos[i]
    f = 0.0
    if r > 0:
        f += pos[i - cols] - xi
    elif fixed:
        f -= xi
    if r < rows - 1:
        f += pos[i + cols] - xi
    elif fixed:
        f -= xi
    if c > 0:
        f += pos[i - 1] - xi
    elif fixed:
        f -= xi
    if c < cols - 1:
        f += pos[i + 1] - xi
    elif fixed:
        f -= xi
    vel[i] += w * (tension * f + frc[i] - damping * vel[i])
    frc[i] = 0.0


@helper
def sheet_step(pos, vel, frc, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 2-D stencil of a uniform rows × cols lattice, row-major.

    The edges are peeled off the interior, whose loop has no tests (so LLVM vectorises it); the
    neighbours are summed in the same order everywhere (up, down, left, right), as before.
    """
    w = dt * inv_mass
    for r in range(rows):
        if r == 0 or r == rows - 1:
            for c in range(cols):
                _sheet_cell(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed)
            continue
        _sheet_cell(pos, vel, frc, r, 0, rows, cols, w, tension, damping, fixed)
        # row views indexed from 1: no index can be negative, so no wraparound test per access
        up, mid, down = pos[(r - 1) * cols:r * cols], pos[r * cols:(r + 1) * cols], pos[(r + 1) * cols:(r + 2) * cols]
        v, fr = vel[r * cols:(r + 1) * cols], frc[r * cols:(r + 1) * cols]
        for c in range(1, cols - 1):
            xi = mid[c]
            f = (up[c] - xi) + (down[c] - xi) + (mid[c - 1] - xi) + (mid[c + 1] - xi)
            v[c] += w * (tension * f + fr[c] - damping * v[c])
            fr[c] = 0.0
        if cols > 1:
            _sheet_cell(pos, vel, frc, r, cols - 1, rows, cols, w, tension, damping, fixed)
    for i in range(rows * cols):
        pos[i] += dt * vel[i]
