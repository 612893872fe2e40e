"""Mass-spring instruments (Howard & Rimell 2003, Cymatic): cells, n-dimensional lattices and springs.

These blocks declare; the graph layer fuses every group of touching cells, lattices and
springs into ONE structure-of-arrays network updated by `network_step` (CSR spring lists) or
`string_step` / `sheet_step` / `cube_step` (stencils for regular 1-D, 2-D and 3-D lattices), so a 100,000-cell
instrument is one loop and compiles as fast as a 10-cell one.

Integration is the half-step (leapfrog) scheme: velocities live half a sample ahead of positions,
    v[n+½] = v[n−½] + dt/m · (F_springs(x[n]) + F[n] − γ·v[n−½]),   x[n+1] = x[n] + dt·v[n+½],
stable while dt²·Σk/m + dt·γ/m < 2 for every cell (Gershgorin bound of the stiffness matrix).
A cell's `position` output is x[n], its `velocity` v[n−½]; its `force` input acts on v[n+½].
"""
import math

from .vocabulary import Block, In, Out, Param, helper
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
    """δ = gap − (x_b − x_a); F = k·δ^α + λ·δ^α·δ̇ (≥ 0) pushes a and b apart while δ > 0, else 0.  Ref: Hunt & Crossley 1975; Chatziioannou & van Walstijn 2015.

    A link of the mass-spring family between any two points (cells, lattice cells, `point`
    blocks, ground). `scheme: energy` (the default, law `contact`, blocks/impact.py): the
    discrete gradient F = (V(δ[n+1]) − V(δ[n−1]))/(δ[n+1] − δ[n−1]) + λ·δ[n]^α·δ̇, solved after
    the step; with λ = 0 the energy of the model and the contact (V = k·δ^(α+1)/(α+1)) is kept
    to rounding. `scheme: explicit` (law `contact_explicit`, blocks/laws.py): F from x[n] and δ̇
    from v[n−½], cheaper, drifts in energy. The stability check takes k·α·range^(α−1), its
    stiffest slope up to a penetration `range`. `force` reads the force of the previous step.
    """

    a = Param("", doc="a point: a cell block's name, lattice[i, j], a point block's name, or ground (x = 0)")
    b = Param("", doc="the other point (at rest at x_a + gap, above a)")
    gap = Param(0.0, unit="m", minimum=-1e3, maximum=1e3, live=False, doc="x_b − x_a at first touch")
    k = Param(1e4, unit="N/m^α", minimum=0.0, maximum=1e18, live=False, doc="stiffness")
    alpha = Param(1.0, minimum=1.0, maximum=10.0, live=False, doc="exponent α ≥ 1")
    damping = Param(0.0, unit="N·s/m^(α+1)", minimum=0.0, maximum=1e18, live=False, doc="Hunt–Crossley λ")
    range = Param(0.001, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="the largest penetration the stability check covers")
    scheme = Param("energy", choices=("energy", "explicit"), doc="energy: discrete gradient; explicit: F from x[n]")
    force = Out(doc="F [N], ≥ 0 (one sample late: the force of the last step)")
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @staticmethod
    def law_of(values):
        from . import impact, laws
        return impact.Contact if values["scheme"] == "energy" else laws.ExplicitContact


@helper
def network_step(pos, vel, frc, inv_m, damp, anchor, cid, rowptr, col, kr, jrow, jcol, jk, scale, dt):
    """One half-step of a fused network with CSR spring lists (unsigned indices).

    Per cell i of component c = cid[i]: scale[c] = (1/mass, tension, damping) at this sample;
    inv_m and anchor are relative to the component (0 inverse mass: locked), damp is added to the
    component's damping (per-cell overrides). Springs inside
    components (rowptr/col/kr, scaled by the tension) and joins (jrow/jcol/jk, absolute).
    The cells are the first rowptr.shape[0] − 1 entries; pos and vel may hold extra points after
    them (ground, driven points, hammers: blocks/points.py), which this step leaves alone.
    """
    n = rowptr.shape[0] - 1
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
def string_step(pos, vel, frc, drv, inv_mass, tension, damping, dt, fixed):
    """The 1-D stencil of a uniform lattice (no locks, cuts, overrides or joins).

    Forces wired into cells are added into frc at the points drv (sorted) before the step. The
    bulk loop never touches frc: a driven interior cell's new velocity (with its force) is
    computed first into frc, the bulk loop then runs over every cell, and the driven cells take
    their velocity back from frc (which is cleared). The ends read frc anyway.
    """
    n = pos.shape[0]
    w = dt * inv_mass
    end = tension if fixed else 0.0
    if n == 1:
        vel[0] += w * (frc[0] - 2.0 * end * pos[0] - damping * vel[0])
        frc[0] = 0.0
    else:
        for k in range(drv.shape[0]):
            i = drv[k]
            if 0 < i < n - 1:
                frc[i] = vel[i] + w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) + frc[i] - damping * vel[i])
        vel[0] += w * (tension * (pos[1] - pos[0]) - end * pos[0] + frc[0] - damping * vel[0])
        frc[0] = 0.0
        for i in range(1, n - 1):
            vel[i] += w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) - damping * vel[i])
        vel[n - 1] += w * (tension * (pos[n - 2] - pos[n - 1]) - end * pos[n - 1] + frc[n - 1]
                           - damping * vel[n - 1])
        frc[n - 1] = 0.0
        for k in range(drv.shape[0]):
            i = drv[k]
            if 0 < i < n - 1:
                vel[i] = frc[i]
                frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def _pull(f, pos, i, step, lower, upper, fixed, xi):
    """f plus the pull on cell i (position xi) of its two neighbours `step` apart along one axis;
    a missing one (not `lower` / not `upper`) is the fixed boundary's ghost at 0, or nothing."""
    if lower:
        f += pos[i - step] - xi
    elif fixed:
        f -= xi
    if upper:
        f += pos[i + step] - xi
    elif fixed:
        f -= xi
    return f


@helper
def _sheet_velocity(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed):
    """A cell's next velocity, its force included, with every boundary test (the edges)."""
    i = r * cols + c
    xi = pos[i]
    f = _pull(0.0, pos, i, cols, r > 0, r < rows - 1, fixed, xi)
    f = _pull(f, pos, i, 1, c > 0, c < cols - 1, fixed, xi)
    return vel[i] + w * (tension * f + frc[i] - damping * vel[i])


@helper
def _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, before):
    """The cells of the interior rows that the bulk loop must not decide: the first and last
    column, and the driven cells. `before` the bulk loop: each one's next velocity (its force
    included) into frc; after it: back into vel, frc cleared."""
    k = 4.0 if fixed else 3.0                                # springs pulling a side cell back
    for r in range(1, rows - 1):
        i = r * cols                                         # column 0
        j = i + cols - 1                                     # column cols - 1 (i itself when cols = 1)
        if not before:
            vel[i] = frc[i]
            vel[j] = frc[j]
            frc[i] = frc[j] = 0.0
        elif cols == 1:
            frc[i] = _sheet_velocity(pos, vel, frc, r, 0, rows, cols, w, tension, damping, fixed)
        else:
            f = (pos[i - cols] + pos[i + cols]) + pos[i + 1] - k * pos[i]
            frc[i] = vel[i] + w * (tension * f + frc[i] - damping * vel[i])
            f = (pos[j - cols] + pos[j + cols]) + pos[j - 1] - k * pos[j]
            frc[j] = vel[j] + w * (tension * f + frc[j] - damping * vel[j])
    for k in range(drv.shape[0]):
        i = drv[k]
        r, c = i // cols, i % cols
        if r < 1 or r > rows - 2 or c < 1 or c > cols - 2:
            continue                       # an edge cell: done above, or read by the edge rows
        if before:
            f = (pos[i - cols] + pos[i + cols]) + (pos[i - 1] + pos[i + 1]) - 4.0 * pos[i]
            frc[i] = vel[i] + w * (tension * f + frc[i] - damping * vel[i])
        else:
            vel[i] = frc[i]
            frc[i] = 0.0


@helper
def _sheet_bulk(up, mid, down, v, w, tension, damping):
    """Every interior row at once as one run (the views start one row apart; indexed from 1, so
    no index can be negative and there is no wraparound test per access): no tests, vectorised.
    The first and last columns come out wrong here and are set aside before, restored after.
    Σ neighbours − 4·x (rather than Σ (neighbour − x)): three fewer operations a cell, 1.4× faster."""
    for j in range(1, mid.shape[0] - 1):
        f = (up[j] + down[j]) + (mid[j - 1] + mid[j + 1]) - 4.0 * mid[j]
        v[j] += w * (tension * f - damping * v[j])


@helper
def _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed):
    """A cell's next velocity in a planes × rows × cols lattice, its force included, with every
    boundary test (the faces)."""
    s0 = rows * cols
    i = a * s0 + b * cols + c
    xi = pos[i]
    f = _pull(0.0, pos, i, s0, a > 0, a < planes - 1, fixed, xi)
    f = _pull(f, pos, i, cols, b > 0, b < rows - 1, fixed, xi)
    f = _pull(f, pos, i, 1, c > 0, c < cols - 1, fixed, xi)
    return vel[i] + w * (tension * f + frc[i] - damping * vel[i])


@helper
def _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, before):
    """The cells of the interior rows of the interior planes that the bulk loop must not decide:
    their first and last column, and the driven cells. `before` the bulk loop: each one's next
    velocity (its force included) into frc; after it: back into vel, frc cleared."""
    for a in range(1, planes - 1):
        for b in range(1, rows - 1):
            i = (a * rows + b) * cols                        # column 0
            j = i + cols - 1                                 # column cols - 1 (i itself when cols = 1)
            if before:
                frc[i] = _cube_velocity(pos, vel, frc, a, b, 0, planes, rows, cols, w, tension, damping, fixed)
                if j != i:
                    frc[j] = _cube_velocity(pos, vel, frc, a, b, cols - 1, planes, rows, cols, w, tension, damping,
                                            fixed)
            else:
                vel[i] = frc[i]
                vel[j] = frc[j]
                frc[i] = frc[j] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        a, r = i // (rows * cols), i % (rows * cols)
        b, c = r // cols, r % cols
        if a < 1 or a > planes - 2 or b < 1 or b > rows - 2 or c < 1 or c > cols - 2:
            continue                       # on a face or in a set-aside column: read where it is done
        if before:
            frc[i] = _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed)
        else:
            vel[i] = frc[i]
            frc[i] = 0.0


@helper
def _cube_bulk(back, up, mid, down, front, v, w, tension, damping):
    """The interior rows of one interior plane as one run (views one plane or one row apart,
    indexed from 1: no tests, vectorised); the first and last columns come out wrong here and
    are set aside before, restored after."""
    for j in range(1, mid.shape[0] - 1):
        f = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1]) - 6.0 * mid[j]
        v[j] += w * (tension * f - damping * v[j])


@helper
def cube_step(pos, vel, frc, drv, planes, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 3-D stencil of a uniform planes × rows × cols lattice, row-major (the 7-point
    Laplacian; the CSR path took 7-10× the C FDTD's time on a cube).

    The interior rows of each interior plane are one loop with no tests (`_cube_bulk`); the cells
    it must not decide (first and last columns, driven cells at drv) are computed first into frc
    and restored after; the cells on the faces have every boundary test.
    """
    w = dt * inv_mass
    s0 = rows * cols
    n = planes * s0
    bulk = planes > 2 and rows > 2
    if bulk:
        _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, True)
        for a in range(1, planes - 1):
            lo = a * s0 + cols                               # (a, 1, 0)
            hi = lo + (rows - 2) * cols                      # (a, rows - 1, 0), not included
            _cube_bulk(pos[lo - s0:hi - s0], pos[lo - cols:hi - cols], pos[lo:hi], pos[lo + cols:hi + cols],
                       pos[lo + s0:hi + s0], vel[lo:hi], w, tension, damping)
        _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, False)
    for a in range(planes):
        face = not bulk or a == 0 or a == planes - 1
        for b in range(rows):
            if face or b == 0 or b == rows - 1:
                for c in range(cols):
                    i = (a * rows + b) * cols + c
                    vel[i] = _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed)
                    frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def sheet_step(pos, vel, frc, drv, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 2-D stencil of a uniform rows × cols lattice, row-major.

    The interior rows are one loop with no tests (`_sheet_bulk`); the cells it must not decide
    (first and last columns, driven cells at drv) are computed first into frc and restored after;
    the first and last rows have every boundary test. The bulk never reads or clears frc.
    """
    w = dt * inv_mass
    n = rows * cols
    _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, True)
    if rows > 2:
        _sheet_bulk(pos[:n - 2 * cols], pos[cols:n - cols], pos[2 * cols:], vel[cols:n - cols], w, tension, damping)
    _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, False)
    for r in range(0, rows, max(rows - 1, 1)):              # rows 0 and rows - 1
        for c in range(cols):
            i = r * cols + c
            vel[i] = _sheet_velocity(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed)
            frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]
