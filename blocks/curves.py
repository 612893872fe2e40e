"""Curves shared by blocks of different families: the bow's friction curve and a table lookup,
used by the `bow` block (blocks/coupling.py) and the mass-spring `friction` link
(blocks/massspring/friction.py), so both compute the same force."""
import math

from .vocabulary import helper


@helper
def friction_curve(dv, mus, mud, v0, eps):
    """Hyperbolic friction curve, odd in dv, its sign jump smoothed over |dv| ≲ eps."""
    w = math.sqrt(dv * dv + eps * eps)
    if w == 0.0:
        return 0.0
    a = abs(dv)
    mu = mud + (mus - mud) * v0 / (v0 + a) if v0 + a > 0.0 else mus
    return dv / w * mu


@helper
def table_lookup(table, u):
    """Linear interpolation in `table` at fractional index u, the end values held outside."""
    last = len(table) - 1
    if u <= 0.0:
        return table[0]
    if u >= last:
        return table[last]
    i = int(u)
    return table[i] + (u - i) * (table[i + 1] - table[i])
