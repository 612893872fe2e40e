"""The members of the mass-spring family and the points they name.

A member is one of
    a body          a `cell` (one cell) or a `lattice` (`shape`: cells on a grid, some cut out):
                    its cells are the network's, in its arrays x, v and f from slot 0
    a driven point  a block declared DrivenPoint (the `point` block): one point whose position
                    follows its input `x`
    a link          a block declared Link (spring, contact, hammer, friction, a plugin's link):
                    it joins the points its `ends` parameters name by the law `law_of(values)`
                    gives (laws.py; None: the linear spring, on the CSR lists)

A link's `a`/`b` (a hammer's `at`) is one of

    NAME            a `cell` block, or a `point` block (a position driven by a signal or a device)
    NAME[i, ...]    one cell of a `lattice`
    ground          the fixed point x = 0 (a reserved word: it never names a block)

These extra points live after the network's cells in its arrays x, v and f (slots n, n + 1, …,
n = the number of cells), where `network_step` leaves them alone; `points_step` (steps.py) runs
first in every step of a network that has them:

    ground   x = v = 0 always (its f collects the links' forces on it, unused)
    point    x[n] = its input `x` at this sample; v[n−½] = (x[n] − x[n−1])·fs (0 at the first
             sample); f = the total force the links exert on it (its `force` output: connect it
             to the device's `force` so the hand feels the model)
    hammer   a mass stepped by its own law (impact.py): x and v along its direction

An extra point has no inverse mass in the network: the links move it not (a hammer moves itself).
"""
import re

from ..family import touching
from ..numbers import whole_number

GROUND = "ground"
CELL_PORTS = {"force": "input", "position": "output", "velocity": "output"}
_REF = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[([-0-9 ,.]*)\])?\s*")


class Link:
    """What a link block of the mass-spring family declares, beside `family = MassSpring`: a
    mixin, `class Spring(Link, Block, name="spring")` (examples/law_plugin/ adds one)."""

    ends = ("a", "b")      # the parameters naming the two points it joins (a hammer: `at` only)
    owns_point = False     # it brings its own extra point (a hammer: its mass), after the others

    @staticmethod
    def law_of(values):
        """The Law (laws.py) of a link with these parameter values; None: the linear spring,
        on the CSR path of `network_step`."""
        raise NotImplementedError


class DrivenPoint:
    """What a driven point block declares (a mixin, as Link): one extra point of its network,
    moved to its input `x` every sample; the links never move it."""


def is_link(inst):
    """A link member (a spring, a contact, a plugin's link): it joins the points its ends name."""
    return issubclass(inst.cls, Link)


def is_point_block(inst):
    """A block that is one extra point of its network (a `point`)."""
    return issubclass(inst.cls, DrivenPoint)


def is_lattice(inst):
    """A body of many cells (`shape`), as opposed to a `cell` block."""
    return inst.cls.type_name == "lattice"


def owns_point(inst):
    """A link that brings its own extra point (a hammer: its mass)."""
    return is_link(inst) and inst.cls.owns_point


def law_of(inst):
    """The Law of a link (None: the linear spring, on the CSR path)."""
    return inst.cls.law_of(inst.values)


def ends_of(inst):
    """The parameters naming the points a link joins (`a`, `b`; a hammer's `at`)."""
    return inst.cls.ends


def refs_of(inst):
    """The point references a link's ends hold, as written."""
    return [inst.values[key] for key in ends_of(inst)]


def joins_of(inst):
    """Names of the blocks a member joins (a link: the blocks of its points; ground is none)."""
    if not is_link(inst):
        return ()
    refs = (parse_ref(r) for r in refs_of(inst) if r.strip() != GROUND)
    return [ref[0] for ref in refs if ref]


def group(members):
    """Mass-spring members (instances) grouped by touch: [(bodies, links)] in patch order."""
    out = []
    for touched in touching(list(members), joins_of):
        bodies = [b for b in touched if not is_link(b)]
        links = [b for b in touched if is_link(b)]
        if bodies or links:
            out.append((bodies, links))
    return out


def parse_ref(text):
    """'plate[3, 4]' -> ('plate', (3, 4)); 'bob' -> ('bob', None); None if unreadable."""
    m = _REF.fullmatch(text or "")
    if not m:
        return None
    if m.group(2) is None:
        return m.group(1), None
    try:
        return m.group(1), tuple(whole_number(v) for v in m.group(2).split(","))   # s[2.0] is s[2]
    except ValueError:
        return None


def index_problem(shape, index):
    """What is wrong with cell `index` of a lattice of `shape`, or None."""
    if len(index) != len(shape):
        return f"index {list(index)} has {len(index)} coordinate(s); the lattice has shape {shape}"
    for i, (k, n) in enumerate(zip(index, shape)):
        if not 0 <= k < n:
            return f"index {list(index)} is out of range for shape {shape} (axis {i}: 0 … {n - 1})"
    return None


def layout(n, points, links, refs):
    """{key: slot} of a network's extra points after its n cells: `ground` if a link names it,
    then the point blocks, then the links that own a point (by name)."""
    slots = {}
    if any(ref.strip() == GROUND for ref in refs):
        slots[GROUND] = n
    for inst in points:
        slots[inst.name] = n + len(slots)
    for inst in links:
        if owns_point(inst):
            slots[inst.name] = n + len(slots)
    return slots
