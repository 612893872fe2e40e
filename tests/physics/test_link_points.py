"""Link points (issue 15): `ground`, a driven `point` block, and the `friction` link (the bow's
law between any two points), against closed forms and the bow's curve computed here."""
import math

import numpy as np
import pytest

from hapticgraph import PatchError, load, render

FS = 44100.0


def mu(dv, mus=0.8, mud=0.3, v0=0.1, eps=0.01):
    """The bow's friction curve (blocks/coupling.py), written out again."""
    return dv / math.sqrt(dv * dv + eps * eps) * (mud + (mus - mud) * v0 / (v0 + abs(dv)))


def test_spring_to_ground_is_a_spring_to_a_locked_cell(write_patch):
    """ground is x = 0: a spring to it moves a cell like a spring to a locked cell (different
    arithmetic: the first runs as a link law, the second on the CSR path; so 1e-12 of the swing)."""
    base = ("hapticgraph: 1\nrate: 44100\nblocks:\n  bob: {type: cell, mass: 0.01}\n  wall: {type: cell, locked: true}\n"
            "  s: {type: spring, a: WALL, b: bob, tension: 1000.0}\n"
            "  hit: {type: pluck, time: 0.0, force: 5.0, duration: 0.001}\nconnect:\n  - hit.out -> bob.force\n")
    a = render(load(write_patch(base.replace("WALL", "ground"), "g.yaml")), 0.1, probes=["bob.position"])
    b = render(load(write_patch(base.replace("WALL", "wall"), "w.yaml")), 0.1, probes=["bob.position"])
    x, y = a.probes["bob.position"], b.probes["bob.position"]
    assert np.abs(y).max() > 1e-4
    np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.abs(y).max())


DRIVEN = """
hapticgraph: 1
rate: 44100
blocks:
  hand: {type: point}
  bob: {type: cell, mass: 0.001, damping: 1.0}
  s: {type: spring, a: hand, b: bob, tension: 10000.0}
  lfo: {type: wavetable, shape: sine, frequency: 5.0, amplitude: 0.001}
connect:
  - lfo.out -> hand.x
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_driven_point_moves_the_model_and_feels_it(write_patch, engine):
    """A point follows its input x (a 1 mm, 5 Hz sine); a stiff spring drags a cell along (it
    follows to 1 % at this slow rate); the point's force output is what the spring pulls it with,
    tension·(x_bob − x_hand) of the last step, to rounding; its velocity is the difference of its
    positions. Records are made before the step, so `position` shows the input one sample late."""
    r = render(load(write_patch(DRIVEN)), 0.2, probes=["hand.position", "hand.velocity", "hand.force", "bob.position",
                                                       "lfo.out"], engine=engine)
    xp, vp, fp, xb, u = (r.probes[k] for k in ("hand.position", "hand.velocity", "hand.force", "bob.position",
                                               "lfo.out"))
    np.testing.assert_array_equal(xp[1:], u[:-1])           # x[n] is the input of the step before
    np.testing.assert_allclose(vp[2:], np.diff(xp)[1:] * FS, rtol=1e-9, atol=1e-12)
    # step n puts the point at its input of sample n (read back as xp[n + 1]) and the cell at xb[n]
    np.testing.assert_allclose(fp[1:], 10000.0 * (xb[:-1] - xp[1:]), rtol=1e-12, atol=1e-15)
    assert np.abs(xb[-2000:] - xp[-2000:]).max() < 0.01 * 0.001 * 2


SLIDE = """
hapticgraph: 1
rate: 44100
blocks:
  bob: {{type: cell, mass: 0.01, damping: {damping}}}
  s: {{type: spring, a: ground, b: bob, tension: {k}}}
  rub: {{type: friction, a: ground, b: bob, normal: 1.0, velocity: {belt}}}
connect: []
"""


@pytest.mark.parametrize("belt", [0.5, 1.0, -2.0])
def test_friction_steady_sliding_force_matches_the_law(write_patch, belt):
    """A damped cell on a spring against a belt (a = ground moving at `velocity`): it settles
    where k·x = N·μ(belt) (its velocity → 0, so Δv = belt). Settling time 2m/γ = 10 ms; after 1 s
    what is left is far below 1e-9 of x, so the law is checked to 1e-9."""
    k = 1000.0
    r = render(load(write_patch(SLIDE.format(damping=2.0, k=k, belt=belt))), 1.0, probes=["bob.position", "rub.force"])
    x, f = r.probes["bob.position"], r.probes["rub.force"]
    law = 1.0 * mu(belt)
    assert k * x[-1] == pytest.approx(law, rel=1e-9)
    assert f[-1] == pytest.approx(law, rel=1e-9)


def test_friction_stick_slip(write_patch):
    """Undamped, a slow belt (0.1 m/s), μs = 0.8 > μd = 0.3: the cell sticks to the belt (moves
    with it) until the spring pulls with about μs·N, slips back, and sticks again (stick-slip)."""
    k, belt = 100.0, 0.1
    r = render(load(write_patch(SLIDE.format(damping=0.0, k=k, belt=belt))), 1.0, probes=["bob.velocity",
                                                                                          "bob.position"])
    v, x = r.probes["bob.velocity"], r.probes["bob.position"]
    sticking = np.abs(v - belt) < 0.05 * belt
    assert sticking.mean() > 0.15                          # sticks for a good part of each cycle (24 %)
    assert (v < 0).any()                                   # and slips back
    starts = np.nonzero(sticking[1:] & ~sticking[:-1])[0]
    assert len(starts) >= 3                                # again and again
    assert 0.85 * 0.8 <= k * x.max() <= 1.01 * 0.8        # it breaks away near μs·N


def test_friction_stability_check_names_the_link(write_patch):
    """The check adds N·(μs/ε + (μs − μd)/v0) to the cell's damping: a tiny ε on a light cell is refused."""
    text = SLIDE.format(damping=0.0, k=100.0, belt=0.1).replace("normal: 1.0", "normal: 1.0, smoothing: 0.0001")
    with pytest.raises(PatchError) as err:
        load(write_patch(text))
    assert "'rub'" in str(err.value) and "friction" in str(err.value) and "N·s/m" in str(err.value)


def test_hammer_stability_check_names_the_hammer(write_patch):
    text = ("hapticgraph: 1\nrate: 44100\nblocks:\n"
            "  h: {type: hammer, at: ground, mass: 1.0e-6, k: 1.0e+9, alpha: 1.0}\nconnect: []\n")
    with pytest.raises(PatchError) as err:
        load(write_patch(text))
    assert "'h'" in str(err.value) and "hammer" in str(err.value)
