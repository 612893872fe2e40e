"""Seed 000 Fig. 7: Helmholtz motion of a string bowed through a (simulated) haptic device at 19 kHz.

patches/fig7_bowed_string.yaml: a waveguide string with an explicit control junction at the bow,
the bow block between the junction's sensed velocity and the device's velocity, the friction
force into the junction and its reaction into the device. Ideal Helmholtz motion under the bow:
the string sticks to the bow (v = v_bow) for a fraction 1 − β of each period and flies back at
−v_stick·(1 − β)/β for β, with the string's period N/fs; the displacement is a sawtooth.
The analysis window starts 1.0 s into the stroke (one clean slip per period from ≈ 0.42 s on).
"""
import pathlib

import numpy as np
import pytest

from analysis import estimate_f0
from hapticgraph import load, render
from hapticgraph.devices import open_drivers

PATCH = pathlib.Path(__file__).resolve().parents[2] / "patches" / "fig7_bowed_string.yaml"
STEADY, END = 1.0, 1.5          # s: the analysis window (the stroke lasts 1.6 s)
PROBES = ["j.v", "hand.v", "xs.out", "bow.force", "hand.force"]


def lengths(patch):
    """Round trip N and the nut-side part (both in samples), every delay counted (see the patch)."""
    val = lambda name, key: patch.blocks[name].values[key]          # noqa: E731
    nut_side = val("r1", "length") + val("l2", "length")            # the nut gain adds no delay
    taps = len(val("bridge", "coeffs"))
    bridge_side = 1 + val("r2", "length") + (taps - 1) / 2 + val("l1", "length") + 1   # junction: 1 each way
    return nut_side + bridge_side, nut_side


@pytest.fixture(scope="module")
def bowed():
    patch = load(PATCH)
    drivers = open_drivers(patch)
    r = render(patch, END, probes=PROBES, drivers=drivers)
    fs = r.rate
    n_round, n_nut = lengths(patch)
    s = slice(int(STEADY * fs), int(END * fs))
    out = {k: r.probes[k][s] for k in PROBES}
    out.update(fs=fs, N=n_round, beta=n_nut / n_round, patch=patch, all=r.probes,
               sent=drivers["arm"].force_sent())
    return out


def flybacks(v, v_bow, beta):
    """Sub-sample times of the flyback onsets: v falls through the midpoint between the stick
    plateau (v_bow) and the ideal slip plateau (v_bow − v_bow/β)."""
    thr = v_bow - 0.5 * v_bow / beta
    i = np.where((v[:-1] >= thr) & (v[1:] < thr))[0]
    return i + (v[i] - thr) / (v[i] - v[i + 1])


def test_patch_geometry(bowed):
    assert bowed["N"] == 100 and bowed["fs"] == 19000
    assert bowed["beta"] == pytest.approx(0.2)


def test_bow_is_driven_by_the_device(bowed):
    """The bow velocity is the device's, moving with the hand at 0.2 m/s, and the device feels
    exactly the reaction of the friction force (−F; well below max_force, so unclamped)."""
    vb = bowed["hand.v"]
    assert np.mean(vb) == pytest.approx(0.2, rel=0.01) and np.std(vb) < 1e-3
    f = bowed["all"]["bow.force"]
    np.testing.assert_allclose(bowed["all"]["hand.force"], -f, rtol=0, atol=1e-15)
    np.testing.assert_allclose(bowed["sent"], -f, rtol=0, atol=1e-15)
    assert np.all(f >= 0.0) and np.max(f) <= 0.8 * 0.12 + 1e-12      # 0 ≤ F ≤ μs·P


def test_period_is_the_strings_round_trip(bowed):
    """Period of v under the bow = N/fs to 0.5 %, two ways: the autocorrelation (searched within
    ±50 % of the expected period, so it cannot lock to a multiple) and the flyback times."""
    fs, N, v = bowed["fs"], bowed["N"], bowed["j.v"]
    f_exp = fs / N
    f0 = estimate_f0(v, fs, fmin=f_exp / 1.5, fmax=f_exp * 1.5)
    t = flybacks(v, np.mean(bowed["hand.v"]), bowed["beta"])
    periods = np.diff(t)
    print(f"\nexpected {f_exp:.3f} Hz (N = {N} samples); autocorrelation {f0:.3f} Hz "
          f"({(f_exp / f0 - 1) * 100:+.3f} % period); flybacks {len(t)}, period {periods.mean():.4f} "
          f"± {periods.std():.4f} samples ({(periods.mean() / N - 1) * 100:+.3f} %)")
    assert abs(f_exp / f0 - 1) < 0.005
    assert abs(periods.mean() / N - 1) < 0.005
    # one flyback per period, every period: no double slipping, no missed slip
    assert len(t) == pytest.approx(len(v) / N, abs=1.0)
    assert np.all(np.abs(periods - N) < 0.5)


def test_sticks_for_one_minus_beta_of_each_period(bowed):
    """Fraction of each period with |v − v_bow| < δ, averaged over whole periods: 1 − β ± 0.1.

    δ = μs·P/(2R0): the friction force reaches the string one sample after the junction senses
    it, as F/(2R0) in v, and |F| ≤ μs·P; so δ is the largest correction the bow can make in one
    sample, the resolution with which the explicit junction can hold the string at the bow's
    speed (it contains the stick ripple and the small creep of the smoothed friction curve).
    The slip plateau lies v_bow/β away (5 times the bow velocity), far outside δ."""
    patch, beta, N = bowed["patch"], bowed["beta"], int(bowed["N"])
    mus = patch.blocks["bow"].values["static_friction"]
    pressure = patch.blocks["press"].values["value"]
    r0 = patch.blocks["j"].values["impedance"]
    delta = mus * pressure / (2 * r0)
    v, vb = bowed["j.v"], bowed["hand.v"]
    assert delta < 0.25 * np.mean(vb) / beta
    periods = len(v) // N
    stuck = (np.abs(v - vb) < delta)[: periods * N].reshape(periods, N).mean(axis=1)
    print(f"\nδ = {delta:.3f} m/s; stick fraction {stuck.mean():.3f} (1 − β = {1 - beta:.3f}) over "
          f"{periods} periods, per period {stuck.min():.3f} … {stuck.max():.3f}; stick plateau "
          f"{np.median(v[np.abs(v - vb) < delta]):.3f} m/s, bow {np.mean(vb):.3f} m/s, slip plateau "
          f"{np.median(v[v < np.mean(vb) - 0.5 * np.mean(vb) / beta]):.3f} m/s")
    assert periods >= 40
    assert abs(stuck.mean() - (1 - beta)) <= 0.1
    assert np.ptp(stuck) <= 0.03                         # the same in every period: steady
    # the flyback: v mirrors the stick so that the mean velocity is zero, v_slip ≈ −v_stick(1 − β)/β
    v_stick = np.median(v[np.abs(v - vb) < delta])
    v_slip = np.median(v[v < np.mean(vb) - 0.5 * np.mean(vb) / beta])
    assert v_slip == pytest.approx(-v_stick * (1 - beta) / beta, rel=0.15)


def test_displacement_is_a_sawtooth(bowed):
    """x under the bow: per period one rising ramp (the stick, slope ≈ v_stick) and one fast
    flyback (falling for ≈ β of the period, (1 − β)/β times steeper), peak to peak v_stick·(1 − β)·T."""
    x, v, fs, beta, N = bowed["xs.out"], bowed["j.v"], bowed["fs"], bowed["beta"], int(bowed["N"])
    periods = len(x) // N
    dx = np.diff(x)
    falling = dx < 0
    runs = np.sum(falling[1:] & ~falling[:-1])                      # falling runs that start
    print(f"\n{periods} periods, {runs} flybacks; falling {falling.mean():.3f} of the time "
          f"(β = {beta}); x peak to peak {np.ptp(x) * 1e3:.3f} mm")
    assert abs(runs - periods) <= 1
    assert abs(falling.mean() - beta) < 0.1
    rise = np.mean(dx[~falling]) * fs
    fall = -np.mean(dx[falling]) * fs
    assert fall / rise == pytest.approx((1 - beta) / beta, rel=0.3)
    v_stick = np.median(v[v > 0.5 * np.max(v)])
    assert np.ptp(x[-periods // 2 * N:]) == pytest.approx(v_stick * (1 - beta) * N / fs, rel=0.15)
