"""The mass-spring family (blocks/family.py's protocol): cells, lattices, driven points and links
(Howard & Rimell 2003), fused group by group into a Network (network.py) stepped by the
half-step scheme: `network_step` (CSR) or a stencil for a uniform lattice.
"""
from ..family import Family
from .checks import check_cells, check_members, check_springs, check_stability
from .members import CELL_PORTS, GROUND, is_lattice, is_link, joins_of, refs_of
from .network import network_of


class MassSpring(Family):
    """Cells, lattices and springs (Howard & Rimell 2003), fused group by group into a Network
    stepped by the half-step scheme: `network_step` (CSR) or a stencil for a uniform lattice."""

    point_ports = CELL_PORTS

    @classmethod
    def joins(cls, inst):
        return joins_of(inst)

    @classmethod
    def link_ends(cls, inst):
        if not is_link(inst):
            return []
        return [(r.split("[")[0].strip(), r.strip()) for r in refs_of(inst) if r.strip() != GROUND]

    @classmethod
    def check(cls, blocks, problems, declared, rate):
        members = {name: b for name, b in blocks.items() if b.cls.family is cls}
        before = len(problems.problems)
        if not check_members(members, problems):
            return
        resolved = check_springs(members, blocks, problems, declared)   # not when a link names a block in error
        check_cells(members, problems)      # before anything sized by the cells is built
        if resolved and len(problems.problems) == before:
            check_stability(members, rate, problems)

    @classmethod
    def point_problem(cls, inst, index, port, role):
        if not is_lattice(inst):
            return f"block {inst.name!r} ({inst.cls.type_name}) has no cells to index with {list(index)}"
        return inst.cls.check_cell(inst.values, index, port, role)

    @classmethod
    def build(cls, members, rate, editable=False):
        """The load's network of these members (network_of): the one the checks built, unless a
        Program runs it already; it steps on a stencil unless `editable`."""
        bodies = [b for b in members if not is_link(b)]
        springs = [b for b in members if is_link(b)]
        if not bodies and not springs:
            return None
        net = network_of(bodies, springs, rate)
        net.use_stencils(not editable)
        return net
