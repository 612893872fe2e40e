"""The points a link of the mass-spring family joins besides cells: `ground`, driven points and
hammers. A link's `a`/`b` (a hammer's `at`) is one of

    NAME            a `cell` block, or a `point` block (a position driven by a signal or a device)
    NAME[i, ...]    one cell of a `lattice`
    ground          the fixed point x = 0 (a reserved word: it never names a block)

These extra points live after the network's cells in its arrays x, v and f (slots n, n + 1, …,
n = the number of cells), where `network_step` leaves them alone; `points_step` runs first in
every step of a network that has them:

    ground   x = v = 0 always (its f collects the links' forces on it, unused)
    point    x[n] = its input `x` at this sample; v[n−½] = (x[n] − x[n−1])·fs (0 at the first
             sample); f = the total force the links exert on it (its `force` output: connect it
             to the device's `force` so the hand feels the model)
    hammer   a mass stepped by its own law (blocks/impact.py): x and v along its direction

An extra point has no inverse mass in the network: the links move it not (a hammer moves itself).
"""
from .vocabulary import helper

GROUND = "ground"


def is_point_block(inst):
    """A block that is one extra point of its network (a `point`)."""
    return getattr(inst.cls, "extra_point", False)


def owns_point(inst):
    """A link that brings its own extra point (a hammer: its mass)."""
    return getattr(inst.cls, "owns_point", False)


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


@helper
def points_step(pos, vel, frc, rowptr, pt_slot, pt_in, dt):
    """The extra points before a step: forces on them cleared (a point's `force` output is what
    the links put there during the last step), each driven point moved to its input
    pt_in[j, 0] with the velocity of the move (pt_in[j, 1]: 1 once it has moved)."""
    n = rowptr.shape[0] - 1
    for i in range(n, pos.shape[0]):
        frc[i] = 0.0
    for j in range(pt_slot.shape[0]):
        i = pt_slot[j]
        x = pt_in[j, 0]
        if pt_in[j, 1] > 0.5:
            vel[i] = (x - pos[i]) / dt
        else:
            vel[i] = 0.0
            pt_in[j, 1] = 1.0
        pos[i] = x
