"""More members of the mass-spring family (issue 15): a driven `point`, the `hammer` and the
`friction` link. Their points and laws: blocks/points.py, blocks/impact.py, blocks/friction.py.
"""
from .vocabulary import Block, Out, Param
from .network import MassSpring

POINT_DOC = "a point: a cell block's name, lattice[i, j], a point block's name, or ground (x = 0)"


class Point(Block, name="point"):
    """x[n] = the input x; v[n−½] = (x[n] − x[n−1])·fs; force = Σ of the links' forces on it (one step late).  Ref: Berdahl et al. 2009 (the device as a point of the model).

    A point of the mass-spring family whose position is driven: connect a device's `x` (or any
    signal) to `x`, join it to the model with links (spring, contact, friction: `a: NAME`), and
    send its `force` back to the device's `force` input, so the hand feels what it touches. It has
    no mass: the links never move it. Its velocity is the difference of its last two positions
    (0 on the first sample). An implicit contact (blocks/impact.py) extrapolates it one sample.
    """

    x = Param(0.0, unit="m", minimum=-1e3, maximum=1e3, doc="the position it follows (e.g. a device's x)")
    force = Out(doc="the total force of the links on it [N] (send it to the device)")
    position = Out(doc="x[n] [m]")
    velocity = Out(doc="v[n−½] [m/s]")
    family = MassSpring
    extra_point = True
    drawing = {"dot": "point", "mermaid": ("((", "))")}


class Hammer(Block, name="hammer"):
    """δ = x_h − side·x_at; F = k·δ^α + λ·δ^α·δ̇ (≥ 0) while δ > 0 pushes the hammer back and `at` along its side; m·ẍ_h = −F.  Ref: Hunt & Crossley 1975; Chaigne & Askenfelt, JASA 95 (1994).

    A mass `mass` resting against point `at` (touching: δ = 0 at the start, every point starts at
    0), launched into it at `speed` m/s (positive towards the point) at `time` seconds (at the
    nearest sample; negative: no timed launch) and again on every rising edge of `strike` through
    0.5, with the speed `speed` has at that sample (connect a signal to `speed` to override the
    patch value). Between launches it flies freely (no gravity, no damping) and bounces off the
    point. `side: up` (the default) strikes from below: the point is pushed towards +x; `down`
    strikes from above, towards −x. Its outputs are along its direction of travel: `position` is
    its displacement towards the point (0 at rest, so δ = position − side·x_at), `velocity` its
    speed towards it (v[n−½]), `force` the contact force F ≥ 0 of the last step. The contact is
    energy-consistent (discrete gradient, blocks/impact.py): with λ = 0 the hammer, the contact
    and the struck model keep their energy to rounding. The stability check covers the contact's
    stiffest slope k·α·range^(α−1) on the struck cell.
    """

    at = Param("ground", doc=POINT_DOC)
    mass = Param(0.01, unit="kg", above=0.0, maximum=1e6, live=False, doc="the hammer's mass")
    speed = Param(1.0, unit="m/s", minimum=-1e3, maximum=1e3, doc="launch velocity towards the point (live: an input)")
    time = Param(0.0, unit="s", minimum=-1.0, maximum=1e6, live=False, doc="timed launch; negative: only on strike")
    strike = Param(0.0, minimum=-1e9, maximum=1e9, doc="trigger: a launch on each rise through 0.5 (live: an input)")
    k = Param(1e4, unit="N/m^α", minimum=0.0, maximum=1e18, live=False, doc="contact stiffness")
    alpha = Param(1.0, minimum=1.0, maximum=10.0, live=False, doc="exponent α ≥ 1 (felt: about 2.5)")
    damping = Param(0.0, unit="N·s/m^(α+1)", minimum=0.0, maximum=1e18, live=False, doc="Hunt–Crossley λ")
    side = Param("up", choices=("up", "down"), doc="up: strikes from below, pushing the point to +x; down: to −x")
    range = Param(0.001, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="the largest penetration the stability check covers")
    force = Out(doc="contact force F [N], ≥ 0 (the last step's)")
    position = Out(doc="displacement towards the point [m]")
    velocity = Out(doc="velocity towards the point [m/s]")
    family = MassSpring
    owns_point = True
    ends = ("at",)
    drawing = {"dot": "invtriangle", "mermaid": ("[/", "\\]")}

    @staticmethod
    def law_of(values):
        from . import impact
        return impact.Hammer


class Friction(Block, name="friction"):
    """Δv = (v_a + velocity) − v_b; F = max(normal, 0)·μ(Δv) on b and −F on a, μ the bow's curve (or table).  Ref: Berdahl et al. 2009 Sec. 3.2; Woodhouse & Galluzzo, Acta Acustica 90 (2004).

    The `bow` block's friction law as a link of the mass-spring family between any two points: a
    rubbed glass or plate (a = a `point` driven by the device, b = the plate's cell) or a bowed
    cell (a = ground, `velocity` the bow speed). μ(Δv) = Δv/√(Δv² + ε²)·(μd + (μs − μd)·v0/(v0 +
    |Δv|)), or the table over table_range, held at its ends. Explicit in the half-step scheme: F
    from v[n−½] enters v[n+½] (blocks/friction.py). `normal` and `velocity` are live (inputs). The
    stability check adds the curve's steepest |dF/dΔv| at normal = max(normal, range) to both
    cells' damping (dt·γ/m < 2). `force` reads the force on b of the last step.
    """

    a = Param("ground", doc=POINT_DOC + "; its surface moves at v_a + velocity")
    b = Param("", doc="the rubbed point")
    normal = Param(0.5, unit="N", minimum=0.0, maximum=1e6, doc="normal (bow) force (live: an input)")
    velocity = Param(0.0, unit="m/s", minimum=-1e3, maximum=1e3, doc="the surface's speed added to v_a (live)")
    static_friction = Param(0.8, minimum=0.0, maximum=10.0, live=False, doc="μs at Δv = 0")
    dynamic_friction = Param(0.3, minimum=0.0, maximum=10.0, live=False, doc="μd at large sliding speed")
    slip_velocity = Param(0.1, unit="m/s", above=0.0, maximum=1e3, live=False, doc="v0")
    smoothing = Param(0.01, unit="m/s", above=0.0, maximum=1e3, live=False, doc="ε, the smoothed sign jump")
    table = Param([], minimum=-10.0, maximum=10.0, max_items=4096, doc="optional: μ over table_range")
    table_range = Param([-1.0, 1.0], unit="m/s", minimum=-1e3, maximum=1e3, min_items=2, max_items=2,
                        doc="[Δv of the first entry, of the last]")
    range = Param(0.0, unit="N", minimum=0.0, maximum=1e6, live=False,
                  doc="the largest normal force the stability check covers, if above `normal` (a connected normal varies)")
    force = Out(doc="friction force on b [N] (the last step's)")
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @classmethod
    def check(cls, p, fs):
        if len(p.table) == 1:
            yield "table", "a friction table needs at least 2 entries (or none, for the curve)"
        if not p.table_range[1] > p.table_range[0]:
            yield "table_range", "table_range must be [low, high] with low < high"

    @staticmethod
    def law_of(values):
        from . import friction
        return friction.Friction
