"""Nonlinear links of the mass-spring family (issue 15): cubic and table springs, the Hunt–Crossley
contact and a plugin law, against independent solutions (scipy) and closed forms."""
import math
import pathlib

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hapticgraph import PatchError, load, render

FS = 44100.0
DT = 1.0 / FS
EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


def one_mass(link, force, mass=0.01):
    """A cell `bob` joined to a locked cell `wall` by `link`, struck by a one-sample force."""
    return ("hapticgraph: 1\nrate: 44100\nblocks:\n  wall: {type: cell, locked: true}\n"
            f"  bob: {{type: cell, mass: {mass!r}}}\n  s: {{{link}}}\n"
            f"  hit: {{type: pluck, time: 0.0, force: {force!r}, duration: 1.0e-6}}\n"
            "connect:\n  - hit.out -> bob.force\n")


def up_crossings(t, x):
    """Times where x crosses 0 upwards, linearly interpolated between samples."""
    i = np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


@pytest.mark.parametrize("force", [20.0, 60.0, 180.0])
def test_cubic_spring_frequency_against_scipy(write_patch, force):
    """m·x'' = −(k·x + k3·x³): the rendered period against DOP853 (rtol 1e-12) started from the
    same x(0) = 0, v = v[½]. Three amplitudes (0.14, 0.4, 1 mm) span k3·A²/k from 0.02 to 1,
    so the frequency rises by up to 40 % over the linear 50.3 Hz. Tolerance 1e-4: the half-step
    scheme's period error is (ω·dt)²/24 ≈ 1e-5 here, the crossing interpolation's less, and
    starting the ODE half a sample early changes the energy by (ω·dt/2)²/2 ≈ 1e-5."""
    m, k, k3 = 0.01, 1000.0, 1e9
    path = write_patch(one_mass(f"type: spring, a: wall, b: bob, law: cubic, tension: {k}, k3: {k3}, range: 0.002",
                                force, m))
    r = render(load(path), 1.0, probes=["bob.position", "bob.velocity"])
    x, v0 = r.probes["bob.position"], r.probes["bob.velocity"][1]
    t = np.arange(len(x)) * DT
    rendered = np.diff(up_crossings(t, -x)[[0, -1]])[0] / (len(up_crossings(t, -x)) - 1)
    sol = solve_ivp(lambda _, y: [y[1], -(k * y[0] + k3 * y[0] ** 3) / m], (0.0, 1.0), [0.0, v0],
                    method="DOP853", rtol=1e-12, atol=1e-15, events=lambda _, y: y[0])
    ups = sol.t_events[0][sol.y_events[0][:, 1] < 0]       # x crossing 0 downwards: −x up
    reference = (ups[-1] - ups[0]) / (len(ups) - 1)
    linear = 2 * math.pi * math.sqrt(m / k)
    assert reference < linear * (1 - 1e-3)                   # the hardening is real (0.75 % … 40 %)
    assert rendered == pytest.approx(reference, rel=1e-4)


def test_table_law_of_a_straight_line_is_the_linear_spring(write_patch):
    """A two-sample table [−k·r, k·r] over [−r, r] is F = k·d: it matches the linear spring to
    rounding (different arithmetic, so 1e-9, not bit for bit)."""
    k = 1000.0
    table = write_patch(one_mass(f"type: spring, a: wall, b: bob, law: table, table: [{-k * 0.01}, {k * 0.01}], "
                                 "table_range: [-0.01, 0.01]", 5.0))
    linear = write_patch(one_mass(f"type: spring, a: wall, b: bob, tension: {k}", 5.0))
    a = render(load(table), 0.1, probes=["bob.position"]).probes["bob.position"]
    b = render(load(linear), 0.1, probes=["bob.position"]).probes["bob.position"]
    assert np.abs(b).max() > 1e-5
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_contact_alpha_one_time_and_rebound(write_patch, engine):
    """A 10 g cell struck towards a locked cell (α = 1, λ = 0, k = 10⁴ N/m): contact lasts
    π·√(m/k) = 3.14 ms and it rebounds at its strike speed. Tolerances: the contact starts and
    ends between samples, so its measured time is within 2·dt; each switch changes the momentum
    by at most k·(v·dt)·dt, a relative (ω·dt)² = 5e-4, so the speed within 1.1e-3."""
    m, k = 0.01, 1e4
    path = write_patch(one_mass(f"type: contact, a: wall, b: bob, gap: 0.0, k: {k}, alpha: 1.0, damping: 0.0",
                                -5.0, m))
    r = render(load(path), 0.02, probes=["bob.position", "bob.velocity"], engine=engine)
    x, v = r.probes["bob.position"], r.probes["bob.velocity"]
    strike = v[1]
    assert strike < 0
    inside = np.nonzero(x < 0)[0]
    assert np.all(np.diff(inside) == 1)                    # one contact
    assert len(inside) * DT == pytest.approx(math.pi * math.sqrt(m / k), abs=2 * DT)
    assert v[-1] == pytest.approx(-strike, rel=1.1e-3)
    assert x[-1] > 0                                       # it left


def test_contact_force_output_and_damping(write_patch):
    """λ > 0: the rebound is slower than the strike, and `force` is ≥ 0 and nonzero in contact."""
    text = one_mass("type: contact, a: wall, b: bob, k: 1.0e5, alpha: 1.5, damping: 20.0", -5.0)
    text = text.replace("blocks:\n", "blocks:\n  meter: {type: gain, gain: 1.0}\n")
    text += "  - s.force -> meter.in\n"
    r = render(load(write_patch(text)), 0.02, probes=["bob.velocity", "meter.out"])
    f, v = r.probes["meter.out"], r.probes["bob.velocity"]
    assert f.min() >= 0 and f.max() > 0
    assert 0 < v[-1] < -v[1]


def test_stability_check_names_the_nonlinear_link(write_patch):
    """The check takes the cubic law's stiffest slope, tension + 3·k3·range², not the tension."""
    path = write_patch(one_mass("type: spring, a: wall, b: bob, law: cubic, tension: 1.0, k3: 1.0e15, range: 0.01",
                                1.0))
    with pytest.raises(PatchError) as err:
        load(path)
    assert "'s'" in str(err.value) and "cubic" in str(err.value)


def test_plugin_law_example():
    """examples/law_plugin: a saturating spring from a plugin; compiled ≡ python, and the force
    never exceeds its limit (so the swing is wider than the linear spring's)."""
    p = load(EXAMPLES / "law_plugin" / "saturating_spring.yaml")
    a = render(p, 0.05, probes=["bob.position"]).probes["bob.position"]
    b = render(p, 0.05, probes=["bob.position"], engine="python").probes["bob.position"]
    assert np.array_equal(a, b)
    v0 = 50.0 * DT / 0.01
    assert np.abs(a).max() > 1.05 * v0 * math.sqrt(0.01 / 1000.0)
