"""Mass-spring instruments (Howard & Rimell 2003, Cymatic): the bodies — cells and n-dimensional
lattices — and the driven `point`. Their links: links.py.

These blocks declare; the family (family.py) fuses every group of touching cells, lattices, points
and links into ONE structure-of-arrays network (network.py) updated by `network_step` (CSR spring
lists) or `string_step` / `sheet_step` / `cube_step` (stencils for regular 1-D, 2-D and 3-D
lattices), so a 100,000-cell instrument is one loop and compiles as fast as a 10-cell one.

Integration is the half-step (leapfrog) scheme: velocities live half a sample ahead of positions,
    v[n+½] = v[n−½] + dt/m · (F_springs(x[n]) + F[n] − γ·v[n−½]),   x[n+1] = x[n] + dt·v[n+½],
stable while dt²·Σk/m + dt·γ/m < 2 for every cell (Gershgorin bound of the stiffness matrix).
A cell's `position` output is x[n], its `velocity` v[n−½]; its `force` input acts on v[n+½].
A uniform lattice on a stencil runs the same recurrence in one pass over its positions, with
v[n−½] = (x[n] − x[n−1])·fs computed where it is read (stencils.py).
"""
import math

from ..vocabulary import Block, In, Out, Param
from .checks import BYTES_PER_CELL, MAX_CELLS
from .family import MassSpring
from .members import CELL_PORTS, DrivenPoint, index_problem

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


class Point(DrivenPoint, Block, name="point"):
    """x[n] = the input x; v[n−½] = (x[n] − x[n−1])·fs; force = Σ of the links' forces on it (one step late).  Ref: Berdahl et al. 2009 (the device as a point of the model).

    A point of the mass-spring family whose position is driven: connect a device's `x` (or any
    signal) to `x`, join it to the model with links (spring, contact, friction: `a: NAME`), and
    send its `force` back to the device's `force` input, so the hand feels what it touches. It has
    no mass: the links never move it. Its velocity is the difference of its last two positions
    (0 on the first sample). An implicit contact (impact.py) extrapolates it one sample.
    """

    x = Param(0.0, unit="m", minimum=-1e3, maximum=1e3, doc="the position it follows (e.g. a device's x)")
    force = Out(doc="the total force of the links on it [N] (send it to the device)")
    position = Out(doc="x[n] [m]")
    velocity = Out(doc="v[n−½] [m/s]")
    family = MassSpring
    drawing = {"dot": "point", "mermaid": ("((", "))")}
