"""Checks of the links of the mass-spring family: the points they name (`a`, `b`; a hammer's
`at`: a cell block, a lattice's cell (not cut, index in range), a `point` block, or `ground`), and
the stability of a link's own mass (a hammer's)."""
from . import points as pts
from .network import (STABILITY_BOUND, ends_of, index_problem, is_link, is_mass_spring, law_of, parse_ref,
                      stability_number)


def check_springs(blocks, problems, declared=()):
    """Link references name existing points (cells not cut, point blocks, ground), and not the
    same point twice. (`declared`: every block name of the patch, also those with problems.)
    True if every reference found its point (a block with problems of its own is not found)."""
    resolved = True
    for inst in blocks.values():
        if not is_mass_spring(inst) or not is_link(inst):
            continue
        cells = []
        for key in ends_of(inst):
            where = f"block {inst.name!r} ({inst.cls.type_name}): parameter {key!r}"
            found = _point_ref(inst.values[key], blocks, declared, lambda m: problems.add(inst.line_of(key),
                                                                                          f"{where}: {m}"))
            if found is not None:
                cells.append(found)
            resolved = resolved and found is not None
        if len(cells) == 2 and cells[0] == cells[1]:
            ref = inst.values[ends_of(inst)[0]].strip()
            problems.add(inst.line, f"block {inst.name!r} ({inst.cls.type_name}): joins cell {ref} to itself")
    return resolved


def _point_ref(text, blocks, declared, fail):
    """(name, index) of a point reference, or None after `fail(message)` (or silently, when the
    block it names has a problem of its own)."""
    ref = parse_ref(text)
    if ref is None or not text:
        fail("write a cell as NAME or NAME[i, j] (a point block as NAME, the fixed point as ground)")
        return None
    name, index = ref
    if name == pts.GROUND and index is None:
        return ref
    target = blocks.get(name)
    if target is None:
        if name not in declared:
            fail(f"no lattice or cell block named {name!r} (nor a point block; the fixed point is ground)")
        return None
    kind = target.cls.type_name
    if not is_mass_spring(target) or is_link(target):
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
        if pts.owns_point(s):
            slope = law_of(s).slope(s.values)
            number = stability_number(1.0 / rate, slope, s.values["mass"], 0.0)
            if number >= STABILITY_BOUND:
                problems.add(s.line, f"block {s.name!r} ({s.cls.type_name}): unstable at {rate:g} Hz: its mass "
                                     f"{s.values['mass']:g} kg against its contact (law {law_of(s).name}, slope up "
                                     f"to {slope:.4g} N/m in its declared range) has dt²·k/m = {number:.3g}, the "
                                     f"half-step scheme needs < {STABILITY_BOUND:g} (a heavier hammer, a smaller "
                                     "range or k, or a higher rate)")
