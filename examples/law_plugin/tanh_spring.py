"""A plugin link law: a saturating spring, F = limit·tanh(tension·d / limit), in about 30 lines.

A Law (its name, the parameters it reads, a @helper force function, its stiffest slope) and a
link block of the mass-spring family that uses it (a Link: `law_of` names the law); nothing in
hapticgraph's graph/ changes.
"""
import math

from hapticgraph.blocks import Block, Param, helper
from hapticgraph.blocks.massspring import Law, Link, MassSpring


@helper
def tanh_force(d, v, p):
    """F_b = −limit·tanh(tension·d/limit)."""
    return -p[1] * math.tanh(p[0] * d / p[1])


class TanhLaw(Law):
    name = "tanh"
    params = ("tension", "limit")
    force = tanh_force

    @classmethod
    def slope(cls, values):
        return values["tension"]          # the steepest point is d = 0


class TanhSpring(Link, Block, name="tanh_spring"):
    """F = limit·tanh(tension·(x_b − x_a)/limit) on cell a and −F on cell b (a saturating spring)."""

    a = Param("", doc="a cell")
    b = Param("", doc="the other cell")
    tension = Param(100.0, unit="N/m", above=0.0, live=False, doc="stiffness at rest")
    limit = Param(1.0, unit="N", above=0.0, live=False, doc="the largest force")
    family = MassSpring

    @staticmethod
    def law_of(values):
        return TanhLaw
