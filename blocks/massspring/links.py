"""The links of the mass-spring family: `spring`, `contact`, `hammer` and `friction`. Each joins
two points (a hammer: its own mass and one point) by a law: linear (the CSR lists of
`network_step`), or a Law (laws.py: cubic, table, explicit contact; impact.py: the
energy-consistent contact and the hammer; friction.py). The points: members.py.
"""
from ..vocabulary import Block, Out, Param
from .family import MassSpring
from .friction import FrictionLaw
from .impact import ContactLaw, HammerLaw
from .laws import LAWS, ExplicitContactLaw
from .members import Link

POINT_DOC = "a point: a cell block's name, lattice[i, j], a point block's name, or ground (x = 0)"


class Spring(Link, Block, name="spring"):
    """F = f(d) on cell a and −F on cell b, d = x_b − x_a: linear f = tension·d; cubic f = tension·d + k3·d³; table f = T(d) interpolated.  Ref: Howard & Rimell 2003 (joins); Faust mi.lib (nonlinear springs).

    `linear` stays on the CSR path of `network_step`; `cubic` and `table` are link laws
    (laws.py), explicit in the half-step scheme like the linear force. The stability check
    takes each law's stiffest slope over its declared range: tension + 3·k3·range² (cubic), the
    steepest segment of the table (table; outside `table_range` the force is held).
    """

    a = Param("", doc="a cell: a cell block's name or lattice[i, j]")
    b = Param("", doc="the other cell")
    tension = Param(100.0, unit="N/m", minimum=0.0, maximum=1e9, live=False)
    law = Param("linear", choices=("linear", "cubic", "table"), doc="force against extension d = x_b − x_a")
    k3 = Param(0.0, unit="N/m³", minimum=-1e18, maximum=1e18, live=False, doc="cubic: the d³ coefficient")
    range = Param(0.01, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="cubic: the largest |d| the stability check covers")
    table = Param([0.0, 0.0], doc="table: forces [N] at evenly spaced extensions over table_range", min_items=2,
                  max_items=4096)
    table_range = Param([-0.01, 0.01], unit="m", doc="table: [lowest, highest] extension", min_items=2,
                        max_items=2)
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @staticmethod
    def law_of(values):
        return None if values["law"] == "linear" else LAWS[values["law"]]

    @classmethod
    def check(cls, p, fs):
        if p.law == "table" and not p.table_range[1] > p.table_range[0]:
            yield "table_range", f"[lowest, highest] must rise, got {list(p.table_range)}"


class Contact(Link, Block, name="contact"):
    """δ = gap − (x_b − x_a); F = k·δ^α + λ·δ^α·δ̇ (≥ 0) pushes a and b apart while δ > 0, else 0.  Ref: Hunt & Crossley 1975; Chatziioannou & van Walstijn 2015.

    A link of the mass-spring family between any two points (cells, lattice cells, `point`
    blocks, ground). `scheme: energy` (the default, law `contact`, impact.py): the
    discrete gradient F = (V(δ[n+1]) − V(δ[n−1]))/(δ[n+1] − δ[n−1]) + λ·δ[n]^α·δ̇, solved after
    the step; with λ = 0 the energy of the model and the contact (V = k·δ^(α+1)/(α+1)) is kept
    to rounding. `scheme: explicit` (law `contact_explicit`, laws.py): F from x[n] and δ̇
    from v[n−½], cheaper, drifts in energy. The stability check takes k·α·range^(α−1), its
    stiffest slope up to a penetration `range`. `force` reads the force of the previous step.
    """

    a = Param("", doc="a point: a cell block's name, lattice[i, j], a point block's name, or ground (x = 0)")
    b = Param("", doc="the other point (at rest at x_a + gap, above a)")
    gap = Param(0.0, unit="m", minimum=-1e3, maximum=1e3, live=False, doc="x_b − x_a at first touch")
    k = Param(1e4, unit="N/m^α", minimum=0.0, maximum=1e18, live=False, doc="stiffness")
    alpha = Param(1.0, minimum=1.0, maximum=10.0, live=False, doc="exponent α ≥ 1")
    damping = Param(0.0, unit="N·s/m^(α+1)", minimum=0.0, maximum=1e18, live=False, doc="Hunt–Crossley λ")
    range = Param(0.001, unit="m", above=0.0, maximum=1e3, live=False,
                  doc="the largest penetration the stability check covers")
    scheme = Param("energy", choices=("energy", "explicit"), doc="energy: discrete gradient; explicit: F from x[n]")
    force = Out(doc="F [N], ≥ 0 (one sample late: the force of the last step)")
    family = MassSpring
    drawing = {"dot": "diamond", "mermaid": ("{", "}")}

    @staticmethod
    def law_of(values):
        return ContactLaw if values["scheme"] == "energy" else ExplicitContactLaw


class Hammer(Link, Block, name="hammer"):
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
    energy-consistent (discrete gradient, impact.py): with λ = 0 the hammer, the contact
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
        return HammerLaw


class Friction(Link, Block, name="friction"):
    """Δv = (v_a + velocity) − v_b; F = max(normal, 0)·μ(Δv) on b and −F on a, μ the bow's curve (or table).  Ref: Berdahl et al. 2009 Sec. 3.2; Woodhouse & Galluzzo, Acta Acustica 90 (2004).

    The `bow` block's friction law as a link of the mass-spring family between any two points: a
    rubbed glass or plate (a = a `point` driven by the device, b = the plate's cell) or a bowed
    cell (a = ground, `velocity` the bow speed). μ(Δv) = Δv/√(Δv² + ε²)·(μd + (μs − μd)·v0/(v0 +
    |Δv|)), or the table over table_range, held at its ends. Explicit in the half-step scheme: F
    from v[n−½] enters v[n+½] (friction.py). `normal` and `velocity` are live (inputs). The
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
        return FrictionLaw
