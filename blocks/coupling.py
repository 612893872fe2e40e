"""Haptic coupling to digital waveguides (Berdahl et al. 2009): control junctions, estimators, couplings, bow.

Sign conventions shared by every block here: waves are velocity waves (m/s); a junction's
`force` is the force ON THE STRING, positive along the string's positive velocity; the device
(or any body on the other side of the coupling) receives the opposite force. A coupling's
`force` acts on body 2 (the string: x2, v2) and `reaction` = −force on body 1 (the device: x1, v1).
"""
import math

from .curves import friction_curve, table_lookup
from .vocabulary import Block, Buffer, In, Out, Param, State, helper  # noqa: F401

_IMPEDANCE_DOC = "wave impedance R0 of the string at the junction (a force F launches F/(2R0) each way)"


class ExplicitJunction(Block, name="explicit_junction"):
    """v[n] = aL[n] + bR[n−1] + F[n−1]/(2R0), bL[n] = bR[n−1] + F[n−1]/(2R0), aR[n] = aL[n−1] + F[n−1]/(2R0).  Ref: Berdahl et al. 2009 Fig. 4, Sec. 3.1.

    The sensor (which outputs `v`) and the actuator sit one sample apart: each direction of travel
    passes one unit delay, and the force enters the waveguide one sample after the sample in which
    it was computed, so no output reads `force` in the same sample: `force` does not feed through
    and a loop v -> coupling -> force needs no other delay. Feedthrough: aL -> v only.
    """

    aL = In(doc="velocity wave arriving from the left, travelling right")
    bR = In(doc="velocity wave arriving from the right, travelling left")
    force = In(doc="force on the string at the control point [N]")
    aR = Out(doc="velocity wave leaving to the right")
    bL = Out(doc="velocity wave leaving to the left")
    v = Out(doc="string velocity at the sensor [m/s]")
    impedance = Param(1.0, unit="N·s/m", above=0.0, maximum=1e9, live=False, doc=_IMPEDANCE_DOC)
    a1 = State(0.0, doc="aL[n−1]")
    b1 = State(0.0, doc="bR[n−1]")
    f1 = State(0.0, doc="F[n−1]")

    @staticmethod
    def derive(p, fs):
        return {"g": 0.5 / p.impedance}

    @staticmethod
    def output(aL, a1, b1, f1, g):
        # Fig. 4 read literally gives aR[n] = aL[n−1] + F[n]/(2R0): the actuator would inject the
        # force of the current sample into the right-going wave, so `force` would feed through to
        # aR and the usual loop junction.v -> spring_damper -> junction.force would be an algebraic
        # loop (the scheduler orders whole blocks). Injecting F[n−1] instead keeps the paper's point
        # (the force is applied one sample after the sensor reads the velocity that produced it),
        # keeps v and bL exactly as in Fig. 4, and launches equal waves F/(2R0) both ways in the
        # same sample.
        h = g * f1
        bl = b1 + h
        return a1 + h, bl, aL + bl

    @staticmethod
    def update(aL, bR, force):
        return aL, bR, force


class ImplicitJunction(Block, name="implicit_junction"):
    """F = 2R0/(2R0 + R + k/fs)·(k(xm − p·x[n−1]) + R·vm − (R + k/fs)(aL + bR)); v = aL + bR + F/(2R0), aR = aL + F/(2R0), bL = bR + F/(2R0), x = p·x[n−1] + v/fs.  Ref: Berdahl et al. 2009 eqs. (1)–(4).

    The spring k and damper R between the device (xm, vm) and the string are solved together with
    the junction in the same sample (no unit delays). `force` is F, the force on the string; the
    device receives −F. k and R are read every sample, so they can be modulated (binding,
    plucking by releasing k); a nonlinear damper (bowing) needs its own solution, Berdahl et al. 2009 Sec. 3.3.
    """

    aL = In(doc="velocity wave arriving from the left, travelling right")
    bR = In(doc="velocity wave arriving from the right, travelling left")
    xm = In(doc="device position [m]")
    vm = In(doc="device velocity [m/s]")
    aR = Out(doc="velocity wave leaving to the right")
    bL = Out(doc="velocity wave leaving to the left")
    v = Out(doc="string velocity at the control point [m/s]")
    x = Out(doc="estimated string displacement at the control point [m]")
    force = Out(doc="force on the string [N]; the device receives −force")
    impedance = Param(1.0, unit="N·s/m", above=0.0, maximum=1e9, live=False, doc=_IMPEDANCE_DOC)
    k = Param(200.0, unit="N/m", minimum=0.0, maximum=1e9, doc="coupling spring stiffness")
    R = Param(0.5, unit="N·s/m", minimum=0.0, maximum=1e9, doc="coupling damping")
    pole = Param(0.9999, above=0.0, below=1.0, live=False,
                 doc="leak p of the displacement estimator x[n] = p·x[n−1] + v[n]/fs")
    x1 = State(0.0, doc="x[n−1]")

    @staticmethod
    def derive(p, fs):
        return {"r2": 2.0 * p.impedance, "g": 0.5 / p.impedance, "dt": 1.0 / fs}

    @staticmethod
    def output(aL, bR, xm, vm, k, R, pole, x1, r2, g, dt):
        s = aL + bR
        kd = k * dt
        f = r2 / (r2 + R + kd) * (k * (xm - pole * x1) + R * vm - (R + kd) * s)
        h = g * f
        v = s + h
        return aL + h, bR + h, v, pole * x1 + v * dt, f

    @staticmethod
    def update(x):
        return x


class VelocityEstimator(Block, name="velocity_estimator"):
    """d[n] = (in[n] − in[n−1])·fs (d[0] = 0); out[n] = (1 − a)·d[n] + a·out[n−1], a = exp(−2π·cutoff/fs), a = 0 when cutoff = 0.  Ref: Berdahl et al. 2009 Fig. 6.

    The first sample has no predecessor, so its difference is 0: a device resting away from 0
    gives no start-up spike. `cutoff` is a design constant of the estimator (not live).
    """

    x = In(name="in", doc="position [m]")
    y = Out(name="out", doc="velocity [m/s]")
    cutoff = Param(0.0, unit="Hz", minimum=0.0, maximum=1e6, live=False,
                   doc="one-pole low-pass smoothing of the difference; 0: none")
    x1 = State(0.0, doc="in[n−1]")
    y1 = State(0.0, doc="out[n−1]")
    primed = State(0.0, doc="1 once a previous input exists")

    @classmethod
    def check(cls, p, fs):
        if p.cutoff >= 0.5 * fs:
            yield "cutoff", f"cutoff must be below half the rate ({0.5 * fs:g} Hz)"

    @staticmethod
    def derive(p, fs):
        return {"a": math.exp(-2.0 * math.pi * p.cutoff / fs) if p.cutoff > 0.0 else 0.0}

    @staticmethod
    def output(x, x1, y1, primed, a, fs):
        d = (x - x1) * fs if primed > 0.5 else 0.0
        return (1.0 - a) * d + a * y1

    @staticmethod
    def update(x, y):
        return x, y, 1.0


class DisplacementEstimator(Block, name="displacement_estimator"):
    """out[n] = p·out[n−1] + in[n]/fs (a leaky integrator; p < 1 forgets a velocity offset).  Ref: Berdahl et al. 2009 eq. (3)."""

    x = In(name="in", doc="velocity [m/s]")
    y = Out(name="out", doc="displacement [m]")
    pole = Param(0.9999, above=0.0, below=1.0, live=False, doc="leak p, close to but below 1")
    y1 = State(0.0, doc="out[n−1]")

    @staticmethod
    def derive(p, fs):
        return {"dt": 1.0 / fs}

    @staticmethod
    def output(x, y1, pole, dt):
        return pole * y1 + x * dt

    @staticmethod
    def update(y):
        return y


class SpringDamper(Block, name="spring_damper"):
    """force = k(x1 − x2) + R(v1 − v2) (on body 2, the string), reaction = −force (on body 1, the device).  Ref: Berdahl et al. 2009 eq. (1)."""

    x1 = In(doc="position of body 1, e.g. the device [m]")
    v1 = In(doc="velocity of body 1 [m/s]")
    x2 = In(doc="position of body 2, e.g. the string [m]")
    v2 = In(doc="velocity of body 2 [m/s]")
    force = Out(doc="force on body 2 [N]")
    reaction = Out(doc="force on body 1 [N]")
    k = Param(200.0, unit="N/m", minimum=0.0, maximum=1e9, doc="stiffness")
    R = Param(0.5, unit="N·s/m", minimum=0.0, maximum=1e9, doc="damping")

    @staticmethod
    def output(x1, v1, x2, v2, k, R):
        f = k * (x1 - x2) + R * (v1 - v2)
        return f, -f


@helper
def _pluck(d, k, release, engaged, side):
    """(force, engaged, side) after one sample of the plucker with finger offset d = x1 − x2."""
    if engaged < 0.5 and side != 0.0 and d * side < 0.0:
        engaged = 1.0
    if engaged > 0.5:
        f = k * d
        if abs(f) > release:
            return 0.0, 0.0, (1.0 if d > 0.0 else -1.0)
        return f, 1.0, side
    if side == 0.0 and d != 0.0:
        side = 1.0 if d > 0.0 else -1.0
    return 0.0, 0.0, side


class Plucker(Block, name="plucker"):
    """force = k·(x1 − x2) while engaged, else 0; it releases when |k(x1 − x2)| > release and re-engages when x1 − x2 changes sign from its side at release.  Ref: Berdahl et al. 2009 Sec. 3.2.

    State: `engaged` (0/1) and `side` (the sign of d = x1 − x2 the finger is on, 0 = not yet
    known). It starts disengaged; the first non-zero d sets `side`. Each sample, with d[n]:
    1. disengaged and d·side < 0 (the finger has passed to the other side of the string):
       engage, in this same sample;
    2. engaged: f = k·d; if |f| > release the string slips off: force 0 from this sample on,
       disengaged, side = sign(d); otherwise force f;
    3. disengaged: force 0.
    A finger that crosses so fast that |k·d| > release on the first engaged sample passes
    without plucking. v1 and v2 are accepted (same ports as spring_damper) and unused: no damper.
    """

    x1 = In(doc="finger position [m]")
    v1 = In(doc="unused (no damper)")
    x2 = In(doc="string position [m]")
    v2 = In(doc="unused (no damper)")
    force = Out(doc="force on the string [N]")
    reaction = Out(doc="force on the finger [N]")
    k = Param(200.0, unit="N/m", minimum=0.0, maximum=1e9, doc="stiffness while engaged")
    release = Param(1.0, unit="N", minimum=0.0, maximum=1e9, doc="the spring lets go above this force")
    engaged = State(0.0)
    side = State(0.0)

    @staticmethod
    def output(x1, x2, k, release, engaged, side):
        f, _, _ = _pluck(x1 - x2, k, release, engaged, side)
        return f, -f

    @staticmethod
    def update(x1, x2, k, release, engaged, side):
        _, e, s = _pluck(x1 - x2, k, release, engaged, side)
        return e, s


class Bow(Block, name="bow"):
    """force = max(pressure, 0)·μ(bow_velocity − v), μ(Δv) = Δv/√(Δv² + ε²)·(μd + (μs − μd)·v0/(v0 + |Δv|)), or μ from `table`.  Ref: Berdahl et al. 2009 Sec. 3.2; Woodhouse & Galluzzo, Acta Acustica 90 (2004).

    A nonlinear damper: the friction force drives the string toward the bow's velocity (a
    positive Δv = bow_velocity − v gives a positive force on the string; the bow, i.e. the device,
    receives −force). With ε = smoothing = 0 the curve is the classic hyperbolic one with a sign
    jump at Δv = 0; ε > 0 turns the jump into a steep slope of μs/ε. `table`, when given, replaces
    the curve: μ sampled uniformly from table_range[0] to table_range[1] (m/s), linearly
    interpolated, the end values held outside. The force is computed from v of the same sample,
    so the block needs a string that does not feed through (an explicit_junction's v, a cell's
    velocity); a stick phase then stays smooth while pressure·max|μ'| < 2R0 (junction).
    """

    v = In(doc="string velocity at the bow [m/s]")
    bow_velocity = In(doc="bow velocity [m/s]")
    pressure = In(doc="bow (normal) force [N]; ≤ 0 lifts the bow")
    force = Out(doc="friction force on the string [N]")
    static_friction = Param(0.8, minimum=0.0, maximum=10.0, doc="μs, the friction coefficient at Δv = 0")
    dynamic_friction = Param(0.3, minimum=0.0, maximum=10.0, doc="μd, the limit at large sliding speed")
    slip_velocity = Param(0.1, unit="m/s", above=0.0, maximum=1e3, doc="v0, where μ is halfway from μs to μd")
    smoothing = Param(0.01, unit="m/s", minimum=0.0, maximum=1e3, doc="ε, the width of the smoothed sign jump")
    table = Param([], minimum=-10.0, maximum=10.0, max_items=4096,
                  doc="optional bow table: μ sampled uniformly over table_range; empty: the curve")
    table_range = Param([-1.0, 1.0], unit="m/s", minimum=-1e3, maximum=1e3, min_items=2, max_items=2,
                        doc="[Δv of the first entry, Δv of the last entry]")

    @classmethod
    def check(cls, p, fs):
        if len(p.table) == 1:
            yield "table", "a bow table needs at least 2 entries (or none, for the friction curve)"
        if not p.table_range[1] > p.table_range[0]:
            yield "table_range", "table_range must be [low, high] with low < high"

    structure = ("use_table",)     # a table or the curve; the table itself is data

    @staticmethod
    def derive(p, fs):
        n = len(p.table)
        if n < 2:
            return {"mu_table": (0.0, 0.0), "use_table": False, "v_lo": 0.0, "v_scale": 0.0}
        lo, hi = float(p.table_range[0]), float(p.table_range[1])
        return {"mu_table": tuple(float(m) for m in p.table), "use_table": True,
                "v_lo": lo, "v_scale": (n - 1) / (hi - lo)}

    @staticmethod
    def output(v, bow_velocity, pressure, static_friction, dynamic_friction, slip_velocity, smoothing,
               mu_table, use_table, v_lo, v_scale):
        dv = bow_velocity - v
        if use_table:
            mu = table_lookup(mu_table, (dv - v_lo) * v_scale)
        else:
            mu = friction_curve(dv, static_friction, dynamic_friction, slip_velocity, smoothing)
        return max(pressure, 0.0) * mu
