"""The friction link law (FrictionLaw): the bow's friction curve (blocks/curves.py, also the `bow`
block's) between any two points of the mass-spring family.

Δv = (v_a + velocity) − v_b: point a's surface moves at its own velocity plus the signal
`velocity` (a bow: a = ground and velocity = the bow speed; a rubbing finger: a = a `point`
driven by the device). The force on b is normal·μ(Δv) (−that on a), μ the bow's hyperbolic
curve, odd in Δv with its sign jump smoothed over ε, or its table. Explicit ("pre" phase): F is
taken from v[n−½] and enters v[n+½], like the `bow` block on a cell. The stability check adds
the curve's steepest |dF/dΔv| ≤ N·(μs/ε + (μs − μd)/v0) (the table's steepest segment), with
N = max(normal, range), to the damping γ of both points: dt·γ/m < 2 keeps the sticking phase
from chattering.
"""
from ..curves import friction_curve, table_lookup
from ..vocabulary import helper
from .laws import Law


@helper
def friction_force(d, v, p):
    """F_b = normal·μ(velocity − v). p = (normal, velocity, μs, μd, v0, ε, n, lo, scale, table…)."""
    dv = p[1] - v
    n = int(p[6])
    if n >= 2:
        mu = table_lookup(p[9:9 + n], (dv - p[7]) * p[8])
    else:
        mu = friction_curve(dv, p[2], p[3], p[4], p[5])
    return max(p[0], 0.0) * mu


class FrictionLaw(Law):
    """The bow's friction curve as a link (see the module)."""

    name = "friction"
    params = ("normal", "velocity", "static_friction", "dynamic_friction", "slip_velocity", "smoothing")
    force = friction_force
    controls = ((0, "normal"), (1, "velocity"))

    @classmethod
    def pack(cls, values):
        row = [float(values[p]) for p in cls.params]
        table = [float(t) for t in values["table"]]
        lo, hi = (float(r) for r in values["table_range"])
        if len(table) < 2:
            return row + [0.0, 0.0, 0.0]
        return row + [float(len(table)), lo, (len(table) - 1) / (hi - lo)] + table

    @classmethod
    def slope(cls, values):
        return 0.0

    @classmethod
    def damping_slope(cls, values):
        normal = max(values["normal"], values["range"])
        table = list(values["table"])
        if len(table) >= 2:
            lo, hi = values["table_range"]
            step = (hi - lo) / (len(table) - 1)
            return normal * max(abs(b - a) for a, b in zip(table, table[1:])) / step
        mus, mud = values["static_friction"], values["dynamic_friction"]
        return normal * (mus / values["smoothing"] + abs(mus - mud) / values["slip_velocity"])
