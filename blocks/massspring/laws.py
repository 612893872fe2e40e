"""Link laws of the mass-spring family: how a link (a nonlinear spring, a contact) turns the
extension of its two points into a force.

A law is a small class: its `name`, the link block's `params` it reads (packed per link into a
row of floats, in that order), a @helper `force(d, v, p)` -> the force on point b (−F acts on
point a) for the extension d = x_b − x_a, its rate v = v_b − v_a and the link's row p, and
`slope(values)`: the stiffest |dF/dd| over the link's declared range, which the stability check
adds to the Σk of both its cells. Subclassing registers the law and builds its per-link loop
(`NAME_links`, a @helper in the law's module), so a plugin adds a law without touching graph/:
see examples/law_plugin/. A law's class is named `…Law`, apart from the link block that uses it.

A law's `phase` says where its loop runs in the step:
- "pre" (the default; cubic, table, explicit contact, friction): explicit in the half-step scheme,
  F evaluated at x[n] (and v[n−½]) is added into the forces before `network_step`, and enters
  v[n+½] like the linear springs' forces;
- "post" (the energy-consistent contact, the hammer: impact.py): after `network_step` has moved every cell as
  if the link were absent, the law solves for its force from the free positions x̃[n+1] and
  corrects the two points it joins (a force F on a point of inverse mass w adds dt·w·F to v[n+½]
  and dt²·w·F to x[n+1], exactly what adding F before the step would have done). Its loop is the
  class's own `links` @helper (pos, vel, frc, inv_m, scale, cid, ia, ib, prm, io, dt) and may keep
  state in its rows of `prm`.
The linear law keeps its own CSR path (`network_step`). Points beyond the network's cells (ground,
driven points, hammers: members.py) come first in each step (`points_step`, steps.py).
"""
import linecache
import sys

import numpy as np

from ..vocabulary import helper
from .steps import network_step, points_step

LAWS = {}


_LOOP = """
def {name}(pos, vel, frc, ia, ib, prm, io):
    for k in range(ia.shape[0]):
        a = ia[k]
        b = ib[k]
        f = _force(pos[b] - pos[a], vel[b] - vel[a], prm[k])
        frc[a] -= f
        frc[b] += f
        frc[io[k]] = f
"""


def _define(module_name, name, source, names):
    """A function built from `source` in module `module_name`, set as its attribute `name` (so
    a generated kernel can import it) and marked @helper. Its text is kept in linecache, so a
    traceback shows its lines and the C export (hapticgraph.graph.c) reads it as any source."""
    space = dict(names, __name__=module_name)
    text, filename = source.format(name=name), f"<{module_name}.{name}>"
    linecache.cache[filename] = (len(text), None, text.splitlines(True), filename)
    exec(compile(text, filename, "exec"), space)  # noqa: S102
    fn = space[name]
    setattr(sys.modules[module_name], name, fn)
    return helper(fn)


class Law:
    """The protocol of a link law (class attributes and class methods; subclass it)."""

    name = ""
    params = ()
    force = None
    phase = "pre"
    controls = ()             # (column of the link's row, live parameter) set every sample

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name:
            LAWS[cls.name] = cls
            if "links" not in cls.__dict__:
                cls.links = _define(cls.__module__, f"{cls.name}_links", _LOOP, {"_force": cls.__dict__["force"]})

    @classmethod
    def row(cls, values, rate):
        """The link's row in its law's `prm` array (`pack`, unless the law keeps rate-dependent
        state there)."""
        return cls.pack(values)

    @classmethod
    def damping_slope(cls, values):
        """The largest |dF/dv| [N·s/m] over the declared range (the check adds it to γ)."""
        return 0.0

    @classmethod
    def pack(cls, values):
        """The link's row of parameters (floats) its force function reads."""
        return [float(values[p]) for p in cls.params]

    @classmethod
    def slope(cls, values):
        """The stiffest |dF/dd| [N/m] over the link's declared range."""
        raise NotImplementedError


def network_step_for(laws, points=False):
    """The step of a network with nonlinear links of `laws` (Law classes, in order): the extra
    points first (`points`: ground, driven points; members.py), each "pre" law's links add
    their forces, then `network_step`, then each "post" law's links (defined once per
    combination, in this module)."""
    name = "network_step_" + "_".join(law.name for law in laws) + ("_pts" if points else "")
    fn = getattr(sys.modules[__name__], name, None)
    if fn is not None and getattr(fn, "_laws", None) == tuple(laws):
        return fn
    base = ("pos, vel, frc, inv_m, damp, anchor, cid, rowptr, col, kr, jrow, jcol, jk, scale, dt")
    extra = "".join(f", {law.name}_a, {law.name}_b, {law.name}_p, {law.name}_o" for law in laws)
    calls = ["    _points(pos, vel, frc, rowptr, pt_slot, pt_in, dt)\n"] if points else []
    for when in ("pre", "post"):
        if when == "post":
            calls.append(f"    _step({base})\n")
        for i, law in enumerate(laws):
            if law.phase != when:
                continue
            own = f"{law.name}_a, {law.name}_b, {law.name}_p, {law.name}_o"
            calls.append(f"    _l{i}(pos, vel, frc, {own})\n" if when == "pre" else
                         f"    _l{i}(pos, vel, frc, inv_m, scale, cid, {own}, dt)\n")
    source = f"def {{name}}({base}{', pt_slot, pt_in' if points else ''}{extra}):\n{''.join(calls)}"
    names = {f"_l{i}": law.links for i, law in enumerate(laws)}
    fn = _define(__name__, name, source, dict(names, _step=network_step, _points=points_step))
    fn._laws = tuple(laws)
    return fn


# -- the built-in laws ---------------------------------------------------------------------------

@helper
def linear_force(d, v, p):
    """F_b = −tension·d."""
    return -p[0] * d


class LinearLaw(Law):
    """The linear spring where it joins an extra point (ground, a driven point), which the CSR
    lists (cells only) cannot hold; the same force, explicit like them."""

    name = "linear"
    params = ("tension",)
    force = linear_force

    @classmethod
    def slope(cls, values):
        return abs(values["tension"])


@helper
def cubic_force(d, v, p):
    """F_b = −(tension·d + k3·d³)."""
    return -(p[0] * d + p[1] * d * d * d)


class CubicLaw(Law):
    """F = tension·d + k3·d³ (a hardening spring for k3 > 0), checked over |d| ≤ range."""

    name = "cubic"
    params = ("tension", "k3", "range")
    force = cubic_force

    @classmethod
    def slope(cls, values):
        return abs(values["tension"] + 3.0 * values["k3"] * values["range"] ** 2) if values["k3"] >= 0 else max(
            abs(values["tension"]), abs(values["tension"] + 3.0 * values["k3"] * values["range"] ** 2))


@helper
def table_force(d, v, p):
    """F_b = −T(d): linear interpolation of n samples over [lo, hi], held at the ends.
    p = (lo, hi, n, T_0 … T_{n−1})."""
    lo, hi, n = p[0], p[1], int(p[2])
    u = (d - lo) / (hi - lo) * (n - 1)
    if u <= 0.0:
        return -p[3]
    if u >= n - 1:
        return -p[2 + n]
    i = int(u)
    w = u - i
    return -((1.0 - w) * p[3 + i] + w * p[4 + i])


class TableLaw(Law):
    """F = T(d), T sampled at `len(table)` evenly spaced extensions over `table_range`."""

    name = "table"
    params = ("table_range", "table")
    force = table_force

    @classmethod
    def pack(cls, values):
        lo, hi = values["table_range"]
        return [float(lo), float(hi), float(len(values["table"]))] + [float(t) for t in values["table"]]

    @classmethod
    def slope(cls, values):
        lo, hi = values["table_range"]
        t = np.asarray(values["table"], dtype=float)
        return float(np.max(np.abs(np.diff(t))) * (len(t) - 1) / (hi - lo)) if len(t) > 1 else 0.0


@helper
def contact_force(d, v, p):
    """Hunt–Crossley: δ = gap − d; F_b = k·δ^α + λ·δ^α·δ̇ (δ̇ = −v) while δ > 0, at least 0."""
    delta = p[0] - d
    if delta <= 0.0:
        return 0.0
    da = delta ** p[2]
    f = p[1] * da - p[3] * da * v
    return max(0.0, f)


class ExplicitContactLaw(Law):
    """A unilateral Hunt–Crossley spring-damper, explicit (F from x[n], v[n−½]; it drifts in
    energy, see impact.py for the energy-consistent `contact`), checked over penetrations
    δ ≤ range."""

    name = "contact_explicit"
    params = ("gap", "k", "alpha", "damping")
    force = contact_force

    @classmethod
    def slope(cls, values):
        return values["k"] * values["alpha"] * values["range"] ** (values["alpha"] - 1.0)
