"""The checks of the mass-spring family, run when a patch loads: the members are of kinds the
network knows; the points links name (`a`, `b`; a hammer's `at`: a cell block, a lattice's cell
(not cut, index in range), a `point` block, or `ground`); the cells of a patch together; and the
stability of the half-step scheme, cell by cell on the load's network (network.py) up to
EXACT_CELLS cells, from a bound on the declarations above, and of a link's own mass (a hammer's).

`members`: the family's blocks without a problem of their own (name -> instance); `blocks`: every
such block of the patch (so a reference to a block of another kind can be named); `declared`:
every block name of the patch (also those with problems).
"""
import math

import numpy as np

from .members import (GROUND, ends_of, group, index_problem, is_lattice, is_link, is_point_block, law_of,
                      owns_point, parse_ref, refs_of)
from .network import network_of
from .steps import time_step

EXACT_CELLS = 250_000   # networks up to this many cells are checked cell by cell, larger by a bound
MAX_CELLS = 20_000_000
BYTES_PER_CELL = 160   # an upper estimate of the fused arrays per cell (see benchmarks)
STABILITY_BOUND = 2.0
BODIES = ("cell", "lattice")   # the bodies a network holds (Component); plugins add links
# the problems of the stability check, %-formats (so the C export, which checks a host's rate,
# writes them too: graph/c/stability.py)
UNSTABLE = ("block %s (%s): unstable at %g Hz: cell %s has dt²·Σk/m + dt·γ/m = %.3g, the half-step "
            "scheme needs < %g (%s; or raise the rate)")
TENSION_HINT = "largest stable tension %.4g N/m"
JOINS_HINT = "its joins alone are too stiff for it: lower their tension"
MASS_HINT = "smallest stable mass %s%.4g kg"
OWN_MASS = ("block %s (%s): unstable at %g Hz: its mass %g kg against its contact (law %s, slope up to %.4g N/m "
            "in its declared range) has dt²·k/m = %.3g, the half-step scheme needs < %g (a heavier hammer, a "
            "smaller range or k, or a higher rate)")


def stability_number(dt, stiffness_sum, mass, damping):
    """dt²·Σk/m + dt·γ/m: the half-step scheme needs it below STABILITY_BOUND."""
    return dt * dt * stiffness_sum / mass + dt * damping / mass


def stiffness_budget(dt, mass, damping):
    """The Σk a cell of this mass and damping can take at step dt."""
    return (STABILITY_BOUND - dt * damping / mass) * mass / (dt * dt)


def largest_tension(tension, budget, k_own, k_join):
    """The largest stable tension of a lattice whose own springs give k_own at `tension` (the
    joins, k_join, do not scale with it)."""
    return tension * (budget - k_join) / k_own


def smallest_mass(dt, stiffness_sum, damping):
    """The smallest stable mass of a cell with this Σk and damping at step dt."""
    return (dt * dt * stiffness_sum + dt * damping) / STABILITY_BOUND


def check_members(members, problems):
    """Every member is a body, a driven point or a declared Link; False if one is not."""
    ok = True
    for inst in members.values():
        if not (is_link(inst) or is_point_block(inst) or inst.cls.type_name in BODIES):
            problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): a member of the mass-spring "
                                    "family is a cell, a lattice, a point or a link; a link block subclasses "
                                    "Link (hapticgraph.blocks.massspring), see examples/law_plugin/")
            ok = False
    return ok


def check_springs(members, blocks, problems, declared=()):
    """Link references name existing points (cells not cut, point blocks, ground), and not the
    same point twice. (`declared`: every block name of the patch, also those with problems.)
    True if every reference found its point (a block with problems of its own is not found)."""
    resolved = True
    for inst in members.values():
        if not is_link(inst):
            continue
        cells = []
        for key in ends_of(inst):
            where = f"block {inst.name!r} ({inst.cls.type_name}): parameter {key!r}"
            found = _point_ref(inst.values[key], members, blocks, declared,
                               lambda m: problems.add(inst.line_of(key), f"{where}: {m}"))
            if found is not None:
                cells.append(found)
            resolved = resolved and found is not None
        if len(cells) == 2 and cells[0] == cells[1]:
            ref = inst.values[ends_of(inst)[0]].strip()
            problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): joins cell {ref} to itself")
    return resolved


def _point_ref(text, members, blocks, declared, fail):
    """(name, index) of a point reference, or None after `fail(message)` (or silently, when the
    block it names has a problem of its own)."""
    ref = parse_ref(text)
    if ref is None or not text:
        fail("write a cell as NAME or NAME[i, j] (a point block as NAME, the fixed point as ground)")
        return None
    name, index = ref
    if name == GROUND and index is None:
        return ref
    target = blocks.get(name)
    if target is None:
        if name not in declared:
            fail(f"no lattice or cell block named {name!r} (nor a point block; the fixed point is ground)")
        return None
    kind = target.cls.type_name
    if name not in members or is_link(target):
        fail(f"{name!r} is a {kind}, not a lattice, a cell or a point")
        return None
    if "shape" not in target.values:
        if index is not None:
            fail(f"{name!r} is a single {kind}; write it without an index")
            return None
        return ref
    if index is None:
        fail(f"{name!r} is a lattice; name one of its cells as {name}[i, ...]")
        return None
    msg = index_problem(list(target.values["shape"]), list(index))
    if msg:
        fail(msg)
        return None
    if list(index) in [list(i) for i in target.values["cut"]]:
        fail(f"{text.strip()} is cut out of its lattice")
        return None
    return ref


def own_masses(springs):
    """[(link, its law's name, its stiffest slope)] of the links with a mass of their own (a hammer)."""
    return [(s, law_of(s).name, law_of(s).slope(s.values)) for s in springs if owns_point(s)]


def check_own_masses(springs, rate, problems):
    """A link with its own mass (a hammer) against its law's stiffest slope."""
    for s, law, slope in own_masses(springs):
        number = stability_number(time_step(rate), slope, s.values["mass"], 0.0)
        if number >= STABILITY_BOUND:
            problems.add(s.line, OWN_MASS % (repr(s.name), s.cls.type_name, rate, s.values["mass"], law, slope, number,
                                             STABILITY_BOUND))


def _cells(inst):
    return math.prod(int(n) for n in inst.values["shape"]) if is_lattice(inst) else 1


def check_cells(members, problems):
    """All lattices and cells of a patch together hold at most MAX_CELLS cells (each lattice is
    also capped on its own by its check); nothing sized by the cells is built here."""
    total, parts = 0, []
    for inst in sorted((b for b in members.values() if not is_link(b)),
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


class Candidate:
    """A cell the stability check may name: its component's block `inst`, `mass`, Σk
    (`stiffness`: `own` of its lattice's springs and anchors, `join` of its joins and links) and
    `damping`; its `label` (computed when asked: `label_of()`)."""

    def __init__(self, inst, label_of, mass, own, join, damping):
        self.inst, self._label_of = inst, label_of
        self.mass, self.own, self.join, self.damping = float(mass), float(own), float(join), float(damping)
        self.stiffness = self.own + self.join
        self._label = None

    @property
    def label(self):
        if self._label is None:
            self._label = self._label_of()
        return self._label

    @property
    def tension(self):
        """The lattice's tension when a tension hint applies (its own springs scale with it), else None."""
        v = self.inst.values
        return v["tension"] if is_lattice(self.inst) and v["tension"] > 0 and self.own > 0 else None

    @property
    def of_cell(self):
        """'of cell LABEL ' when its mass is its own (cells:), not the lattice's."""
        return f"of cell {self.label} " if is_lattice(self.inst) and self.mass != self.inst.values["mass"] else ""


def _exact_candidates(bodies, springs, rate):
    """From the network's fused arrays: the first movable cell of each distinct (Σk, m, γ) (a
    later one with the same numbers is never the first of the worst)."""
    net = network_of(bodies, springs, rate)
    if net.n == 0:
        return []
    mass, damp = net.masses(), net.dampings() + net.nl_g
    own, joins = net.stiffness_parts(laws=True)
    movable = np.flatnonzero(np.isfinite(mass))
    rows = np.stack([own[movable] + joins[movable], mass[movable], damp[movable]], axis=1)
    _, first = np.unique(rows, axis=0, return_index=True)

    def label_of(cell):
        label = net.component_of(cell).label(cell)
        if cell in net.nl_worst:
            _, link, law, what = net.nl_worst[cell]
            label += f" (its stiffest link: {link!r}, law {law}, {what} in its declared range)"
        return label
    return [Candidate(net.component_of(int(i)).inst, lambda i=int(i): label_of(i), mass[i], own[i], joins[i], damp[i])
            for i in movable[np.sort(first)]]


def _bound_candidates(bodies, springs, rate):
    """The same for a network too big to build at check time, from its declarations: every
    cell is given the most lattice springs a cell of its lattice can have (so the bound never
    passes an unstable network); cells with overrides or joins are taken one by one."""
    joins, gammas = {}, {}
    for s in springs:
        for ref in refs_of(s):
            name, index = parse_ref(ref)
            cell = (name, tuple(index) if index is not None else None)
            law = law_of(s)
            joins[cell] = joins.get(cell, 0.0) + (s.values["tension"] if law is None else law.slope(s.values))
            gammas[cell] = gammas.get(cell, 0.0) + (0.0 if law is None else law.damping_slope(s.values))
    out = []
    for inst in bodies:
        v = inst.values
        if is_point_block(inst):
            continue
        if is_lattice(inst):
            shape = [int(n) for n in v["shape"]]
            fixed = v["boundary"] == "fixed"
            degree = sum(2 if fixed or n >= 3 else (1 if n == 2 else 0) for n in shape)
            own = v["tension"] * degree
            locked = {tuple(i) for i in v["lock"]} | {tuple(c["index"]) for c in v["cells"] if c.get("locked")}
            cut = {tuple(i) for i in v["cut"]}
            overrides = {tuple(c["index"]): c for c in v["cells"]}
            # the first cell with the most springs: any with a fixed boundary (the ghosts count)
            generic = tuple(0 if fixed or n < 3 else 1 for n in shape)
            cells = {generic} | set(overrides) | {i for (n, i) in joins if n == inst.name}
        else:
            own, locked, cut, overrides = 0.0, {None} if v["locked"] else set(), set(), {}
            cells = {None}
        for index in cells:
            if index in locked or index in cut:
                continue
            o = overrides.get(index, {})
            m, g = o.get("mass", v["mass"]), o.get("damping", v["damping"]) + gammas.get((inst.name, index), 0.0)
            label = inst.name if index is None else f"{inst.name}[{', '.join(map(str, index))}]"
            out.append(Candidate(inst, lambda label=label: label, m, own, joins.get((inst.name, index), 0.0), g))
    return out


def stability_candidates(bodies, springs, rate):
    """The cells of one group of touching members that the stability check may name at any rate
    ([Candidate]: the first with the largest stability number is the one; none of the rest can
    be). Exact up to EXACT_CELLS cells, else a bound from the declarations."""
    if not any(not is_point_block(m) for m in bodies):
        return []
    exact = sum(_cells(m) for m in bodies) <= EXACT_CELLS and not _uniform(bodies, springs)
    return (_exact_candidates if exact else _bound_candidates)(bodies, springs, rate)


def worst(candidates, rate):
    """(number, Candidate): the first of the candidates with the largest stability number at rate;
    None when there is none."""
    if not candidates:
        return None
    numbers = stability_number(time_step(rate), np.array([c.stiffness for c in candidates]),
                               np.array([c.mass for c in candidates]), np.array([c.damping for c in candidates]))
    at = int(np.argmax(numbers))
    return float(numbers[at]), candidates[at]


def _uniform(bodies, springs):
    """One lattice with nothing irregular: its bound is exact (every cell has its mass and its
    damping, the most springs are the most any cell has), so no per-cell table is built."""
    if springs or len(bodies) != 1 or not is_lattice(bodies[0]):
        return False
    v = bodies[0].values
    return not v["lock"] and not v["cut"] and not v["cells"]


def rate_limits(members, rate):
    """What the stability check reads of the rate, group by group of the members (name -> instance,
    as loaded at `rate`): [(springs, candidates)] — so the C export checks a host's rate with the
    same numbers (graph/c/stability.py)."""
    return [(springs, stability_candidates(bodies, springs, rate)) for bodies, springs in group(members.values())]


def check_stability(members, rate, problems):
    """Refuse a network whose half-step update would blow up, naming the worst cell."""
    for springs, candidates in rate_limits(members, rate):
        check_own_masses(springs, rate, problems)
        found = worst(candidates, rate)
        if found is not None and found[0] >= STABILITY_BOUND:
            problems.add(found[1].inst.line, unstable(found[0], found[1], rate))


def unstable(number, c, rate):
    """The problem of candidate c, the worst at rate with this stability number: with the
    largest stable value of its lattice's tension (or the smallest mass), others fixed."""
    dt = time_step(rate)
    hints = []
    if c.tension is not None:
        budget = stiffness_budget(dt, c.mass, c.damping)
        hints.append(TENSION_HINT % largest_tension(c.tension, budget, c.own, c.join) if budget > c.join else JOINS_HINT)
    hints.append(MASS_HINT % (c.of_cell, smallest_mass(dt, c.stiffness, c.damping)))
    return UNSTABLE % (repr(c.inst.name), c.inst.cls.type_name, rate, c.label, number, STABILITY_BOUND, "; ".join(hints))
