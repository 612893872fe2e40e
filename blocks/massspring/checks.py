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

EXACT_CELLS = 250_000   # networks up to this many cells are checked cell by cell, larger by a bound
MAX_CELLS = 20_000_000
BYTES_PER_CELL = 160   # an upper estimate of the fused arrays per cell (see benchmarks)
STABILITY_BOUND = 2.0
BODIES = ("cell", "lattice")   # the bodies a network holds (Component); plugins add links


def stability_number(dt, stiffness_sum, mass, damping):
    """dt²·Σk/m + dt·γ/m: the half-step scheme needs it below STABILITY_BOUND."""
    return dt * dt * stiffness_sum / mass + dt * damping / mass


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


def check_own_masses(springs, rate, problems):
    """A link with its own mass (a hammer) against its law's stiffest slope."""
    for s in springs:
        if owns_point(s):
            slope = law_of(s).slope(s.values)
            number = stability_number(1.0 / rate, slope, s.values["mass"], 0.0)
            if number >= STABILITY_BOUND:
                problems.add(s.line, f"block {s.name!r} ({s.cls.type_name}): unstable at {rate:g} Hz: its mass "
                                     f"{s.values['mass']:g} kg against its contact (law {law_of(s).name}, slope up "
                                     f"to {slope:.4g} N/m in its declared range) has dt²·k/m = {number:.3g}, the "
                                     f"half-step scheme needs < {STABILITY_BOUND:g} (a heavier hammer, a smaller "
                                     "range or k, or a higher rate)")


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


def _worst_exact(bodies, springs, rate):
    """The cell of a network farthest from stability, from its fused arrays:
    (number, component inst, label, m, Σk, γ, Σk of its lattice, Σk of its joins, component mass)."""
    net = network_of(bodies, springs, rate)
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


def _worst_bound(bodies, springs, rate):
    """The same for a network too big to build at check time, from its declarations: every
    cell is given the most lattice springs a cell of its lattice can have (so the bound never
    passes an unstable network); cells with overrides or joins are taken one by one."""
    dt = 1.0 / rate
    joins, gammas = {}, {}
    for s in springs:
        for ref in refs_of(s):
            name, index = parse_ref(ref)
            cell = (name, tuple(index) if index is not None else None)
            law = law_of(s)
            joins[cell] = joins.get(cell, 0.0) + (s.values["tension"] if law is None else law.slope(s.values))
            gammas[cell] = gammas.get(cell, 0.0) + (0.0 if law is None else law.damping_slope(s.values))
    best = None
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
            k_join = joins.get((inst.name, index), 0.0)
            number = stability_number(dt, own + k_join, m, g)
            if best is None or number > best[0]:
                label = inst.name if index is None else f"{inst.name}[{', '.join(map(str, index))}]"
                best = (number, inst, label, m, own + k_join, g, own, k_join)
    return best


def _uniform(bodies, springs):
    """One lattice with nothing irregular: its bound is exact (every cell has its mass and its
    damping, the most springs are the most any cell has), so no per-cell table is built."""
    if springs or len(bodies) != 1 or not is_lattice(bodies[0]):
        return False
    v = bodies[0].values
    return not v["lock"] and not v["cut"] and not v["cells"]


def check_stability(members, rate, problems):
    """Refuse a network whose half-step update would blow up, naming the worst cell."""
    for bodies, springs in group(members.values()):
        check_own_masses(springs, rate, problems)
        if not any(not is_point_block(m) for m in bodies):
            continue
        exact = sum(_cells(m) for m in bodies) <= EXACT_CELLS and not _uniform(bodies, springs)
        found = (_worst_exact if exact else _worst_bound)(bodies, springs, rate)
        if found is None or found[0] < STABILITY_BOUND:
            continue
        number, inst, label, m, k, g, k_own, k_join = found
        problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): unstable at {rate:g} Hz: cell "
                                f"{label} has dt²·Σk/m + dt·γ/m = {number:.3g}, the half-step "
                                f"scheme needs < {STABILITY_BOUND:g} ({'; '.join(_hints(found, rate))}; or raise "
                                "the rate)")


def _hints(found, rate):
    """The largest stable value of the component's tension (or the smallest mass), others fixed."""
    number, inst, label, m, k, g, k_own, k_join = found
    dt = 1.0 / rate
    hints = []
    budget = (STABILITY_BOUND - dt * g / m) * m / (dt * dt)   # the Σk the cell can take
    if is_lattice(inst) and inst.values["tension"] > 0 and k_own > 0:
        if budget > k_join:
            # only the lattice's own springs scale with its tension; the joins do not
            hints.append(f"largest stable tension {inst.values['tension'] * (budget - k_join) / k_own:.4g} N/m")
        else:
            hints.append("its joins alone are too stiff for it: lower their tension")
    mass_needed = (dt * dt * k + dt * g) / STABILITY_BOUND     # of the cell at fault
    own_mass = is_lattice(inst) and m != inst.values["mass"]   # its own (cells:), not the lattice's
    hints.append(f"smallest stable mass {f'of cell {label} ' if own_mass else ''}{mass_needed:.4g} kg")
    return hints
