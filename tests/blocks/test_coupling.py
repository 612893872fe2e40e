"""Haptic coupling blocks (seed 000): hand-computed sequences, the block functions called directly
and the same blocks run through both engines; the implicit junction checked against eqs. (1)-(4)."""
import inspect
import math
import os

import numpy as np
import pytest

from hapticgraph.blocks.coupling import (Bow, DisplacementEstimator, ExplicitJunction, ImplicitJunction,
                                         Plucker, SpringDamper, VelocityEstimator)
from hapticgraph import render
from hapticgraph.graph.errors import PatchError
from hapticgraph.graph.patch import load

RATE = 1000  # a pluck of duration 1/RATE at time n/RATE is an exact one-sample impulse at n


@pytest.fixture(scope="module", autouse=True)
def _kernel_cache(tmp_path_factory):
    """Kernels go to a temporary folder unless the session already chose one."""
    if "HAPTICGRAPH_CACHE" in os.environ:
        yield
        return
    os.environ["HAPTICGRAPH_CACHE"] = str(tmp_path_factory.mktemp("kernels"))
    yield
    os.environ.pop("HAPTICGRAPH_CACHE", None)


def sequence(prefix, values, dst):
    """Blocks and connections that feed `values` (one per sample from n = 0) into `dst`:
    one single-sample pluck per non-zero value, all summed into the one input."""
    blocks, conns = [], []
    for n, value in enumerate(values):
        if value != 0.0:
            name = f"{prefix}{n}"
            blocks.append(f"  {name}: {{type: pluck, time: {n / RATE!r}, force: {float(value)!r}, "
                          f"duration: {1.0 / RATE!r}}}")
            conns.append(f"  - {name}.out -> {dst}")
    return blocks, conns


def patch_text(blocks, conns, rate=RATE):
    return "\n".join(["hapticgraph: 1", f"rate: {rate}", "blocks:", *blocks,
                      "connect:" + ("" if conns else " []"), *conns]) + "\n"


def both(tmp_path, text, samples, probes):
    """Render with the compiled kernel and the interpreter; they must agree; the compiled probes."""
    path = tmp_path / "p.yaml"
    path.write_text(text, encoding="utf-8")
    patch = load(path)
    seconds = samples / patch.rate
    a = render(patch, seconds, probes=probes, engine="compiled")
    b = render(patch, seconds, probes=probes, engine="python")
    for k in probes:
        assert len(a.probes[k]) == samples
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12, err_msg=k)
    return a.probes


def drive(block, inputs):
    """A patch text: block `b` (a YAML flow mapping) fed by one-sample impulse sequences."""
    blocks, conns = [f"  b: {block}"], []
    for port, values in inputs.items():
        bl, cn = sequence(f"s_{port}_", values, f"b.{port}")
        blocks += bl
        conns += cn
    return patch_text(blocks, conns)


def step(cls, values, state, **coefs):
    """Call a block's output then update directly; returns (outputs, new state)."""
    env = dict(values, **state, **coefs)
    out = cls.output(*[env[a] for a in inspect.signature(cls.output).parameters])
    outs = out if isinstance(out, tuple) else (out,)
    env.update({o.attr: v for o, v in zip(cls.outputs, outs)})
    new = cls.update(*[env[a] for a in inspect.signature(cls.update).parameters]) if cls.update else ()
    new = new if isinstance(new, tuple) else (new,)
    return outs, dict(zip([s.attr for s in cls.states], new))


def initial(cls):
    return {s.attr: s.initial for s in cls.states}


# -- explicit junction ---------------------------------------------------------------------------
EXPL_IN = {"aL": [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
           "bR": [0.0, 2.0, 0.0, 0.0, 0.0, 0.0],
           "force": [0.0, 0.0, 4.0, 0.0, -8.0, 0.0]}
# R0 = 2: g = 1/(2 R0) = 0.25. v[n] = aL[n] + bR[n-1] + F[n-1]/4, bL[n] = bR[n-1] + F[n-1]/4,
# aR[n] = aL[n-1] + F[n-1]/4
EXPL_OUT = {"aR": [0.0, 1.0, 0.0, 1.0, 0.0, -2.0],
            "bL": [0.0, 0.0, 2.0, 1.0, 0.0, -2.0],
            "v": [1.0, 0.0, 2.0, 1.0, 0.0, -2.0]}


def test_explicit_junction_functions():
    state, got = initial(ExplicitJunction), {k: [] for k in EXPL_OUT}
    coefs = ExplicitJunction.derive(ExplicitJunction.param_tuple()(impedance=2.0), 44100.0)
    assert coefs == {"g": 0.25}
    for n in range(6):
        outs, state = step(ExplicitJunction, {k: v[n] for k, v in EXPL_IN.items()}, state, **coefs)
        for k, v in zip(("aR", "bL", "v"), outs):
            got[k].append(v)
    assert got == EXPL_OUT


def test_explicit_junction_patch(tmp_path):
    text = drive("{type: explicit_junction, impedance: 2.0}", EXPL_IN)
    probes = both(tmp_path, text, 6, ["b.aR", "b.bL", "b.v", "b.force"])
    for k, v in EXPL_OUT.items():
        np.testing.assert_array_equal(probes[f"b.{k}"], v, err_msg=k)
    np.testing.assert_array_equal(probes["b.force"], EXPL_IN["force"])


def test_explicit_junction_force_does_not_feed_through():
    assert "force" not in ExplicitJunction.feedthrough()
    assert ExplicitJunction.feedthrough() == {"aL"}


STRING = """\
  nut:    {type: lowpass, coeffs: [0.25, 0.5, 0.25], gain: -1.0}
  bridge: {type: lowpass, coeffs: [0.25, 0.5, 0.25], gain: -0.999}
  r1:     {type: delay, length: 9}
  r2:     {type: delay, length: 20}
  l1:     {type: delay, length: 20}
  l2:     {type: delay, length: 9}
"""
STRING_CONNECT = """\
  - nut.out -> r1.in
  - r1.out -> j.aL
  - j.aR -> r2.in
  - r2.out -> bridge.in
  - bridge.out -> l1.in
  - l1.out -> j.bR
  - j.bL -> l2.in
  - l2.out -> nut.in
"""


def teleoperated_string(junction):
    """Seed 000 Fig. 4 + Fig. 6: a string with a control junction, bound by spring_damper (explicit)
    or by the junction's own k, R (implicit) to a device held at xm = 1 mm."""
    coupling = ", k: 100.0, R: 0.2" if junction == "implicit_junction" else ""
    text = ("hapticgraph: 1\nrate: 8000\nblocks:\n" + STRING
            + f"  j:    {{type: {junction}, impedance: 1.0{coupling}}}\n"
            + "  xm:   {type: constant, value: 0.001}\n")
    conns = STRING_CONNECT
    if junction == "explicit_junction":
        text += ("  xs:   {type: displacement_estimator, pole: 0.9999}\n"
                 "  link: {type: spring_damper, k: 100.0, R: 0.2}\n")
        conns += ("  - j.v -> xs.in\n  - xm.out -> link.x1\n  - xs.out -> link.x2\n"
                  "  - j.v -> link.v2\n  - link.force -> j.force\n")
    else:
        conns += "  - xm.out -> j.xm\n"
    return text + "connect:\n" + conns


def test_loop_through_explicit_junction_is_not_algebraic(tmp_path):
    """junction.v -> spring_damper -> junction.force closes without any other delay."""
    text = teleoperated_string("explicit_junction")
    probes = both(tmp_path, text, 400, ["j.v", "j.force", "link.force"])
    assert np.all(np.isfinite(probes["j.v"]))
    # the force enters one sample after it is computed: the sensor sees it through bL
    assert probes["link.force"][0] == pytest.approx(0.1)            # k·xm, the string at rest
    assert probes["j.v"][0] == 0.0 and probes["j.v"][1] == pytest.approx(0.1 / 2.0)


LITERAL_JUNCTION = '''\
from hapticgraph.blocks import Block, In, Out, State


class LiteralJunction(Block, name="literal_junction"):
    """aR[n] = aL[n-1] + F[n]/2 (Fig. 4 read literally, R0 = 1)."""
    aL = In()
    bR = In()
    force = In()
    aR = Out()
    bL = Out()
    v = Out()
    a1 = State()
    b1 = State()
    f1 = State()

    @staticmethod
    def output(aL, force, a1, b1, f1):
        return a1 + force / 2, b1 + f1 / 2, aL + b1 + f1 / 2

    @staticmethod
    def update(aL, bR, force):
        return aL, bR, force
'''


def test_fig4_read_literally_would_be_an_algebraic_loop(tmp_path):
    """Why aR injects F[n−1]: a junction whose aR reads F[n] makes the same patch unloadable."""
    (tmp_path / "literal.py").write_text(LITERAL_JUNCTION, encoding="utf-8")
    text = teleoperated_string("explicit_junction").replace("type: explicit_junction", "type: literal_junction")
    path = tmp_path / "literal.yaml"
    path.write_text(text.replace("hapticgraph: 1\n", "hapticgraph: 1\nplugins: [literal.py]\n", 1), encoding="utf-8")
    with pytest.raises(PatchError, match="algebraic loop"):
        load(path)


@pytest.mark.parametrize("junction", ["explicit_junction", "implicit_junction"])
def test_teleoperated_string_settles_to_the_spring_force(tmp_path, junction):
    """Fig. 5: a device held still pulls the string until the string holds still; the leaky
    estimator then forgets x̂, so the spring force tends to k·xm = 0.1 N with either junction."""
    fs = 8000
    force = "link.force" if junction == "explicit_junction" else "j.force"
    probes = both(tmp_path, teleoperated_string(junction), 3 * fs, ["j.v", force])
    f, v = probes[force], probes["j.v"]
    assert np.all(np.isfinite(f)) and np.max(np.abs(v)) < 1.0
    assert abs(f[-1] - 0.1) < 2e-3
    assert np.max(np.abs(v[-fs // 10:])) < 1e-3


# -- implicit junction ---------------------------------------------------------------------------
def test_implicit_junction_one_sample_by_hand():
    # R0 = 1, k = 100, R = 1, fs = 100 (k/fs = 1), p = 0.5, x[n-1] = 0.2
    coefs = ImplicitJunction.derive(ImplicitJunction.param_tuple()(1.0, 100.0, 1.0, 0.5), 100.0)
    out = ImplicitJunction.output(aL=0.3, bR=0.1, xm=0.05, vm=0.4, k=100.0, R=1.0, pole=0.5, x1=0.2, **coefs)
    # F = 2/(2+1+1)·(100(0.05 − 0.1) + 0.4 − 2·0.4) = −2.7; F/(2R0) = −1.35
    np.testing.assert_allclose(out, (-1.05, -1.25, -0.95, 0.0905, -2.7), rtol=0, atol=1e-14)
    # eq. (1) holds with the new displacement: F = k(xm − x) + R(vm − v)
    assert 100.0 * (0.05 - out[3]) + (0.4 - out[2]) == pytest.approx(out[4], abs=1e-13)
    assert ImplicitJunction.update(x=out[3]) == out[3]


def test_implicit_junction_satisfies_equations_2_to_4(tmp_path):
    fs, r0, p = 2000.0, 0.7, 0.995
    text = patch_text([
        f"  j:  {{type: implicit_junction, impedance: {r0}, k: 0.0, R: 0.0, pole: {p}}}",
        "  na: {type: noise, amplitude: 0.5, seed: 11}",
        "  nb: {type: noise, amplitude: 0.3, seed: 12}",
        "  nx: {type: noise, amplitude: 0.002, seed: 13}",
        "  sx: {type: wavetable, shape: sine, frequency: 3.0, amplitude: 0.004}",
        "  nv: {type: noise, amplitude: 0.2, seed: 14}",
        "  k0: {type: constant, value: 300.0}",
        "  kw: {type: wavetable, shape: triangle, frequency: 7.0, amplitude: 250.0}",
        "  r0: {type: constant, value: 1.5}",
        "  nr: {type: noise, amplitude: 1.0, seed: 15}",
    ], ["  - na.out -> j.aL", "  - nb.out -> j.bR", "  - nx.out -> j.xm", "  - sx.out -> j.xm",
        "  - nv.out -> j.vm", "  - k0.out -> j.k", "  - kw.out -> j.k", "  - r0.out -> j.R", "  - nr.out -> j.R"],
        rate=int(fs))
    ports = ["aL", "bR", "xm", "vm", "k", "R", "aR", "bL", "v", "x", "force"]
    n = 3000
    pr = both(tmp_path, text, n, [f"j.{q}" for q in ports])
    aL, bR, xm, vm, k, R, aR, bL, v, x, F = (pr[f"j.{q}"] for q in ports)
    assert np.std(k) > 50.0 and np.std(R) > 0.3 and np.std(xm) > 1e-3      # really driven
    x_prev = np.concatenate(([0.0], x[:-1]))
    tol = dict(rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, aL + bR + F / (2 * r0), **tol)                      # (2)
    np.testing.assert_allclose(aR, aL + F / (2 * r0), **tol)
    np.testing.assert_allclose(bL, bR + F / (2 * r0), **tol)
    np.testing.assert_allclose(x, p * x_prev + v / fs, **tol)                         # (3)
    np.testing.assert_allclose(F, k * (xm - x) + R * (vm - v), **tol)                 # (1)
    closed = 2 * r0 / (2 * r0 + R + k / fs) * (k * (xm - p * x_prev) + R * vm - (R + k / fs) * (aL + bR))
    np.testing.assert_allclose(F, closed, **tol)                                      # (4)


# -- estimators ----------------------------------------------------------------------------------
def test_velocity_estimator_functions():
    a = VelocityEstimator.derive(VelocityEstimator.param_tuple()(0.0), 10.0)["a"]
    assert a == 0.0
    state, got = initial(VelocityEstimator), []
    for x in [1.0, 3.0, 6.0, 6.0, 2.0]:
        (y,), state = step(VelocityEstimator, {"x": x}, state, a=a, fs=10.0)
        got.append(y)
    assert got == [0.0, 20.0, 30.0, 0.0, -40.0]       # the first sample has no predecessor
    a = VelocityEstimator.derive(VelocityEstimator.param_tuple()(1.0), 10.0)["a"]
    assert a == pytest.approx(math.exp(-2 * math.pi / 10))
    state, got = initial(VelocityEstimator), []
    for x in [1.0, 3.0, 6.0]:
        (y,), state = step(VelocityEstimator, {"x": x}, state, a=a, fs=10.0)
        got.append(y)
    np.testing.assert_allclose(got, [0.0, (1 - a) * 20.0, (1 - a) * 30.0 + a * (1 - a) * 20.0], atol=1e-12)


@pytest.mark.parametrize("cutoff", [0.0, 25.0])
def test_velocity_estimator_on_a_ramp(tmp_path, cutoff):
    """x[n] = n/fs − 0.5 (a 1 Hz sawtooth of amplitude 0.5 before it wraps): velocity 1 m/s,
    smoothed: 1 − a^n."""
    text = patch_text([
        "  saw: {type: wavetable, shape: sawtooth, frequency: 1.0, amplitude: 0.5, bandlimited: false}",
        f"  e: {{type: velocity_estimator, cutoff: {cutoff}}}",
    ], ["  - saw.out -> e.in"])
    y = both(tmp_path, text, 200, ["e.out"])["e.out"]
    a = math.exp(-2 * math.pi * cutoff / RATE) if cutoff > 0 else 0.0
    n = np.arange(200)
    np.testing.assert_allclose(y, np.where(n == 0, 0.0, 1.0 - a ** n), rtol=0, atol=1e-9)


def test_displacement_estimator(tmp_path):
    dt = DisplacementEstimator.derive(DisplacementEstimator.param_tuple()(0.5), 10.0)["dt"]
    y, got = 0.0, []
    for x in [1.0, 0.0, 0.0, 2.0]:
        y = DisplacementEstimator.update(DisplacementEstimator.output(x, y, 0.5, dt))
        got.append(y)
    np.testing.assert_allclose(got, [0.1, 0.05, 0.025, 0.2125], rtol=0, atol=1e-15)
    # a constant velocity c: x[n] = c·(1 − p^(n+1))/(1 − p)/fs
    text = patch_text(["  c: {type: constant, value: 0.3}", "  e: {type: displacement_estimator, pole: 0.99}"],
                      ["  - c.out -> e.in"])
    x = both(tmp_path, text, 500, ["e.out"])["e.out"]
    n = np.arange(500)
    np.testing.assert_allclose(x, 0.3 / RATE * (1 - 0.99 ** (n + 1)) / (1 - 0.99), rtol=1e-12, atol=0)


# -- couplings -----------------------------------------------------------------------------------
def test_spring_damper(tmp_path):
    assert SpringDamper.output(0.003, 0.1, -0.001, 0.2, 100.0, 2.0) == pytest.approx((0.2, -0.2), abs=1e-15)
    text = patch_text([
        "  s: {type: spring_damper, R: 2.0}",
        "  x1: {type: constant, value: 0.003}", "  v1: {type: constant, value: 0.1}",
        "  x2: {type: constant, value: -0.001}", "  v2: {type: constant, value: 0.2}",
        "  kw: {type: wavetable, shape: sine, frequency: 10.0, amplitude: 100.0}",
    ], ["  - x1.out -> s.x1", "  - v1.out -> s.v1", "  - x2.out -> s.x2", "  - v2.out -> s.v2",
        "  - kw.out -> s.k"])
    pr = both(tmp_path, text, 100, ["s.force", "s.reaction", "s.k"])
    k = 100.0 * np.sin(2 * np.pi * 10.0 * np.arange(100) / RATE)
    np.testing.assert_allclose(pr["s.k"], k, atol=1e-9)
    np.testing.assert_allclose(pr["s.force"], pr["s.k"] * 0.004 + 2.0 * (0.1 - 0.2), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(pr["s.reaction"], -pr["s.force"])


# finger x1 against a string at x2 = 0; k = 100 N/m, release = 0.5 N
PLUCK_X1 = [-0.002, -0.001, 0.001, 0.003, 0.0045, 0.006, 0.004, 0.001, -0.001, -0.002, 0.0, -0.003, -0.006]
PLUCK_F = [0.0, 0.0, 0.1, 0.3, 0.45, 0.0, 0.0, 0.0, -0.1, -0.2, 0.0, -0.3, 0.0]
#          side set | engaged on crossing | slips | off on the far side | re-engaged by crossing back | slips


def test_plucker_functions():
    state, got = initial(Plucker), []
    for x1 in PLUCK_X1:
        (f, r), state = step(Plucker, {"x1": x1, "x2": 0.0, "v1": 0.0, "v2": 0.0, "k": 100.0, "release": 0.5},
                             state)
        assert r == -f
        got.append(f)
    np.testing.assert_allclose(got, PLUCK_F, rtol=0, atol=1e-15)
    assert state == {"engaged": 0.0, "side": -1.0}


def test_plucker_fast_crossing_passes_without_plucking():
    state = initial(Plucker)
    for x1, f_expect, st in [(-0.001, 0.0, {"engaged": 0.0, "side": -1.0}),
                             (0.01, 0.0, {"engaged": 0.0, "side": 1.0}),       # |k·d| = 1 N > 0.5 at once
                             (0.002, 0.0, {"engaged": 0.0, "side": 1.0})]:
        (f, _), state = step(Plucker, {"x1": x1, "x2": 0.0, "v1": 0.0, "v2": 0.0, "k": 100.0, "release": 0.5},
                             state)
        assert f == f_expect and state == st


def test_plucker_patch(tmp_path):
    text = drive("{type: plucker, k: 100.0, release: 0.5}", {"x1": PLUCK_X1})
    pr = both(tmp_path, text, len(PLUCK_X1), ["b.force", "b.reaction", "b.engaged", "b.side"])
    np.testing.assert_allclose(pr["b.force"], PLUCK_F, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(pr["b.reaction"], -pr["b.force"])
    assert Plucker.feedthrough() == {"x1", "x2", "k", "release"}


# -- bow -----------------------------------------------------------------------------------------
def mu_curve(dv, mus=0.8, mud=0.3, v0=0.1, eps=0.01):
    dv = np.asarray(dv, dtype=float)
    return dv / np.sqrt(dv * dv + eps * eps) * (mud + (mus - mud) * v0 / (v0 + np.abs(dv)))


def bow_coefs(**params):
    p = dict(Bow.default_params(), **params)
    return Bow.derive(Bow.param_tuple()(**p), 44100.0)


def bow(v, vb, pressure, mus=0.8, mud=0.3, v0=0.1, eps=0.01, **params):
    return Bow.output(v, vb, pressure, mus, mud, v0, eps, **bow_coefs(**params))


def test_bow_curve_by_hand():
    # ε = 0: the hyperbolic curve itself; Δv = 0.1: 0.3 + 0.5·0.1/0.2 = 0.55
    assert bow(0.0, 0.1, 2.0, eps=0.0) == pytest.approx(1.1, abs=1e-15)
    # Δv = −0.3: −(0.3 + 0.5·0.1/0.4) = −0.425; a bow slower than the string brakes it
    assert bow(0.5, 0.2, 1.0, eps=0.0) == pytest.approx(-0.425, abs=1e-15)
    assert bow(0.2, 0.2, 1.0, eps=0.0) == 0.0
    # ε = 0.1 at Δv = 0.1: 0.1/√0.02 · 0.55
    assert bow(0.0, 0.1, 1.0, eps=0.1) == pytest.approx(0.55 / math.sqrt(2.0), abs=1e-15)
    assert bow(0.0, 0.1, -1.0) == 0.0                              # a lifted bow exerts nothing
    dv = np.linspace(-2.0, 2.0, 4001)
    mu = np.array([bow(0.0, d, 1.0) for d in dv])
    np.testing.assert_allclose(mu, mu_curve(dv), rtol=0, atol=1e-15)
    np.testing.assert_allclose(mu, -mu[::-1], atol=1e-15)            # odd: friction opposes sliding
    assert np.max(np.abs(np.diff(mu))) < 0.8 * (dv[1] - dv[0]) / 0.01 + 1e-12   # smooth: slope ≤ μs/ε
    assert 0.3 < np.max(mu) < 0.8 and mu[-1] == pytest.approx(0.3 + 0.5 * 0.1 / 2.1, rel=1e-4)


def test_bow_table_by_hand():
    c = bow_coefs(table=np.array([-1.0, 0.0, 1.0, 1.0]), table_range=np.array([-0.3, 0.3]))
    assert c["use_table"] and c["v_scale"] == pytest.approx(3 / 0.6)
    f = lambda dv: Bow.output(0.0, dv, 2.0, 0.8, 0.3, 0.1, 0.01, **c)   # noqa: E731
    assert f(-0.3) == pytest.approx(-2.0) and f(-0.2) == pytest.approx(-1.0)
    assert f(0.05) == pytest.approx(2.0 * 0.75) and f(0.5) == 2.0 and f(-9.0) == -2.0
    assert not bow_coefs()["use_table"]


@pytest.mark.parametrize("table", [None, "short", "long"])
def test_bow_on_an_open_string(tmp_path, table):
    """A bow on an explicit junction with nothing attached (no reflections):
    v[n] = F[n−1]/(2R0), F[n] = P·μ(vb − v[n]): the string is dragged toward the bow velocity."""
    r0, vb, pressure = 1.0, 0.2, 0.5
    extra, mu = "", mu_curve
    if table == "short":
        tab, rng = [-0.8, -0.8, 0.0, 0.8, 0.8], (-0.5, 0.5)
    elif table == "long":
        grid = np.linspace(-0.5, 0.5, 101)
        tab, rng = list(mu_curve(grid, eps=0.05)), (-0.5, 0.5)
    if table:
        extra = f", table: {[float(t) for t in tab]}, table_range: {list(rng)}"
        mu = lambda d: np.interp(d, np.linspace(rng[0], rng[1], len(tab)), tab)   # noqa: E731
    text = patch_text([
        f"  j:  {{type: explicit_junction, impedance: {r0}}}",
        f"  b:  {{type: bow, smoothing: 0.05{extra}}}",
        f"  vb: {{type: constant, value: {vb}}}",
        f"  p:  {{type: constant, value: {pressure}}}",
    ], ["  - j.v -> b.v", "  - b.force -> j.force", "  - vb.out -> b.bow_velocity", "  - p.out -> b.pressure"])
    pr = both(tmp_path, text, 300, ["j.v", "b.force"])
    v_expect, f_expect, v = [], [], 0.0
    for _ in range(300):
        f = pressure * float(mu(vb - v) if table else mu_curve(vb - v, eps=0.05))
        v_expect.append(v)
        f_expect.append(f)
        v = f / (2 * r0)
    np.testing.assert_allclose(pr["j.v"], v_expect, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pr["b.force"], f_expect, rtol=0, atol=1e-12)
    assert 0.0 < pr["j.v"][-1] < vb and pr["b.force"][-1] > 0.0       # pulled toward the bow


def test_bow_drives_helmholtz_motion(tmp_path):
    """Bowing the Fig. 4 string (loop delay 62 samples at 8 kHz) through the explicit junction:
    after the attack the bowed point sticks to the bow (v ≈ vb), then flies back (v < 0) once
    per period, as in seed 000 Fig. 7; both engines agree sample for sample."""
    vb, pressure = 0.5, 0.2
    text = ("hapticgraph: 1\nrate: 8000\nblocks:\n" + STRING
            + "  j:  {type: explicit_junction, impedance: 1.0}\n  b:  {type: bow}\n"
              f"  vb: {{type: constant, value: {vb}}}\n  p:  {{type: constant, value: {pressure}}}\n"
            + "connect:\n" + STRING_CONNECT
            + "  - j.v -> b.v\n  - b.force -> j.force\n  - vb.out -> b.bow_velocity\n  - p.out -> b.pressure\n")
    pr = both(tmp_path, text, 16000, ["j.v", "b.force"])
    v = pr["j.v"][-4000:]
    assert np.all(np.isfinite(pr["j.v"])) and np.max(np.abs(pr["b.force"])) <= pressure * 0.8 + 1e-12
    x = v - v.mean()
    ac = np.array([np.dot(x[:-lag], x[lag:]) for lag in range(40, 90)]) / np.dot(x, x)
    assert 40 + int(np.argmax(ac)) == 62 and np.max(ac) > 0.8          # one slip per period
    assert np.mean(np.abs(v - vb) < 0.1 * vb) > 0.3                      # sticking
    assert np.min(v) < -vb                                               # fast fly-back


# -- declarations and checks ---------------------------------------------------------------------
@pytest.mark.parametrize("block, message", [
    ("{type: velocity_estimator, cutoff: 600.0}", "cutoff"),
    ("{type: bow, table: [0.5]}", "table"),
    ("{type: bow, table_range: [1.0, -1.0]}", "table_range"),
    ("{type: implicit_junction, pole: 1.0}", "pole"),
    ("{type: explicit_junction, impedance: 0.0}", "impedance"),
    ("{type: spring_damper, k: -1.0}", "k"),
])
def test_bad_parameters_are_patch_errors(tmp_path, block, message):
    path = tmp_path / "bad.yaml"
    path.write_text(patch_text([f"  b: {block}"], []), encoding="utf-8")
    with pytest.raises(PatchError) as err:
        load(path)
    assert message in str(err.value)


def test_ports_follow_the_catalogue():
    def names(ports):
        return [p.name for p in ports]
    assert (names(ExplicitJunction.inputs), names(ExplicitJunction.outputs)) == (["aL", "bR", "force"],
                                                                                 ["aR", "bL", "v"])
    assert (names(ImplicitJunction.inputs), names(ImplicitJunction.outputs)) == (
        ["aL", "bR", "xm", "vm"], ["aR", "bL", "v", "x", "force"])
    assert {"impedance", "k", "R", "pole"} <= set(ImplicitJunction.params)
    assert ImplicitJunction.params["k"].live and ImplicitJunction.params["R"].live
    for cls in (SpringDamper, Plucker):
        assert (names(cls.inputs), names(cls.outputs)) == (["x1", "v1", "x2", "v2"], ["force", "reaction"])
    assert (names(Bow.inputs), names(Bow.outputs)) == (["v", "bow_velocity", "pressure"], ["force"])
    for cls in (VelocityEstimator, DisplacementEstimator):
        assert (names(cls.inputs), names(cls.outputs)) == (["in"], ["out"])
    for cls in (ExplicitJunction, ImplicitJunction, VelocityEstimator, DisplacementEstimator, SpringDamper,
                Plucker, Bow):
        assert "Ref:" in cls.__doc__.splitlines()[0]
