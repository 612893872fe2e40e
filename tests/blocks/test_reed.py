"""The reed block: hand-computed values of the STK reed table, the same values through both
engines, and the closed-form blowing threshold of a reed on one cell."""
import numpy as np
import pytest

from hapticgraph import render
from hapticgraph.blocks.reed import Reed
from hapticgraph.graph.patch import load

DEFAULTS = dict(offset=0.6, slope=-0.0008, area=1e-4, impedance=413.0)

# (pressure Pa, v m/s, force N), each worked by hand with the defaults above:
HAND = [
    # Δp = 500 − 413·0.5 = 293.5; r = 0.6 − 0.0008·293.5 = 0.3652; F = 1e-4·293.5·0.3652
    (500.0, 0.5, 0.01071862),
    # Δp = 0 − 413·(−1) = 413; r = 0.6 − 0.3304 = 0.2696; F = 1e-4·413·0.2696
    (0.0, -1.0, 0.01113448),
    # Δp = −1000: r = 0.6 + 0.8 = 1.4, clipped to 1; F = 1e-4·(−1000)·1
    (-1000.0, 0.0, -0.1),
    # Δp = 3000: r = 0.6 − 2.4 = −1.8, clipped to −1; F = 1e-4·3000·(−1)
    (3000.0, 0.0, -0.3),
    # Δp = 750: r = 0.6 − 0.6 = 0, the reed is shut; F = 0
    (750.0, 0.0, 0.0),
    # Δp = 0: no pressure drop, no force whatever the opening
    (413.0, 1.0, 0.0),
]


@pytest.mark.parametrize("pressure,v,force", HAND)
def test_hand_computed(pressure, v, force):
    assert Reed.output(pressure, v, **DEFAULTS) == pytest.approx(force, rel=1e-12, abs=1e-15)


def test_feeds_through_pressure_and_velocity():
    assert Reed.feedthrough() >= {"pressure", "v"}


@pytest.mark.parametrize("pressure,v,force", HAND)
def test_both_engines(tmp_path, pressure, v, force):
    path = tmp_path / "reed.yaml"
    path.write_text("hapticgraph: 1\nrate: 1000\nblocks:\n"
                    f"  p: {{type: constant, value: {pressure!r}}}\n"
                    f"  u: {{type: constant, value: {v!r}}}\n"
                    "  r: {type: reed}\n"
                    "connect:\n  - p.out -> r.pressure\n  - u.out -> r.v\n", encoding="utf-8")
    for engine in ("compiled", "python"):
        got = render(load(path), 0.005, probes=["r.force"], engine=engine).probes["r.force"]
        np.testing.assert_allclose(got, force, rtol=1e-12, atol=1e-15)


# A reed on one cell of mass m, held by 2T (a one-cell fixed lattice), damping γ, blown at p.
# At rest v = 0 and Δp = p; linearised, the reed adds the damping −dF/dv = area·Z·g'(p) with
# g(Δp) = Δp·(offset + slope·Δp), g' = offset + 2·slope·Δp. The cell oscillates by itself when
# the total damping is negative: p > p* = (offset + γ/(area·Z)) / (−2·slope), and its amplitude
# then grows at σ = (−area·Z·g'(p) − γ)/(2m) per second (decays at −σ below p*).
M, T, GAMMA = 1e-4, 500.0, 0.002


def threshold():
    d = DEFAULTS
    return (d["offset"] + GAMMA / (d["area"] * d["impedance"])) / (-2.0 * d["slope"])


def blown(tmp_path, pressure, seconds=1.5):
    path = tmp_path / "blown.yaml"
    path.write_text("hapticgraph: 1\nrate: 44100\nblocks:\n"
                    f"  cell: {{type: lattice, shape: [1], mass: {M!r}, tension: {T!r}, damping: {GAMMA!r}}}\n"
                    f"  mouth: {{type: constant, value: {pressure!r}}}\n"
                    "  r: {type: reed}\n"
                    "connect:\n  - mouth.out -> r.pressure\n  - cell[0].velocity -> r.v\n"
                    "  - r.force -> cell[0].force\n", encoding="utf-8")
    x = render(load(path), seconds, probes=["cell[0].position"]).probes["cell[0].position"]
    # the blowing pressure switched on at t = 0 is a step: it starts the oscillation about the
    # new rest position F(p)/(2T), with an amplitude of that size
    rest = Reed.output(pressure, 0.0, **DEFAULTS) / (2 * T)
    period = int(round(44100 * 2 * np.pi * np.sqrt(M / (2 * T))))
    frames = np.abs(x[: len(x) // period * period] - rest).reshape(-1, period).max(axis=1)
    return frames, period / 44100


@pytest.mark.parametrize("factor", [0.95, 1.1])
def test_blowing_threshold_and_growth_rate(tmp_path, factor):
    p = factor * threshold()
    assert 375.0 < p      # on the falling branch of F(Δp) in both cases, so the test is sharp
    frames, dt = blown(tmp_path, p)
    g1 = DEFAULTS["offset"] + 2 * DEFAULTS["slope"] * p
    sigma = (-DEFAULTS["area"] * DEFAULTS["impedance"] * g1 - GAMMA) / (2 * M)
    t = np.arange(len(frames)) * dt
    early = (t > 0.02) & (t < 0.3)    # linear growth or decay, before the table saturates
    rate = np.polyfit(t[early], np.log(frames[early]), 1)[0]
    if factor > 1:
        assert frames[-1] > 5 * frames[0], "blown above threshold, the reed must start to speak"
    else:
        assert frames[-1] < 0.2 * frames[0], "below threshold the oscillation must die away"
    assert rate == pytest.approx(sigma, rel=0.05)
