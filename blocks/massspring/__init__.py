"""The mass-spring family (Howard & Rimell 2003): cells, lattices, driven points and links, fused
group by group into one structure-of-arrays network per group.

Its modules import one way, each only from those above it in this list:
    steps, stencils   the per-sample steps (@helpers): `network_step`, `points_step`, the stencils
    laws              the link laws (`…Law`: how a link's force follows its extension), then
    impact, friction  the energy-consistent contact and hammer, the friction law
    members           the members' roles (Link, DrivenPoint) and the points they name
    arrays            the fused arrays (components, CSR lists)
    network           the Network: the family's Group and its linear model, built once per load
    checks            the load-time checks (references, sizes, stability)
    family            MassSpring, the Family
    cells, links      the block declarations: cell, lattice, point; spring, contact, hammer, friction
A plugin adds a link: a Law and a Link block of this family (examples/law_plugin/).
"""
from .cells import Cell, Lattice, Point
from .family import MassSpring
from .laws import LAWS, Law
from .links import Contact, Friction, Hammer, Spring
from .members import DrivenPoint, Link, parse_ref
from .network import Network

__all__ = ["Cell", "Contact", "DrivenPoint", "Friction", "Hammer", "LAWS", "Lattice", "Law", "Link", "MassSpring",
           "Network", "Point", "Spring", "parse_ref"]
