"""Every patch in patches/: loads, renders headless, compiled == reference interpreter, physics."""
import numpy as np
import pytest

from analysis import estimate_f0
from project_env import PATCHES
from hapticgraph import render
from hapticgraph.graph.patch import load


@pytest.mark.parametrize("path", PATCHES, ids=[p.stem for p in PATCHES])
def test_compiled_equals_interpreter(path):
    """Sample for sample (≤ 1e-12) on every output and every block output, over 2000 samples."""
    patch = load(path)
    probes = [f"{name}.{port.name}" for name, inst in patch.blocks.items() for port in inst.outputs]
    n = 2000 / patch.rate
    a = render(patch, n, probes=probes, engine="compiled")
    b = render(load(path), n, probes=probes, engine="python")
    np.testing.assert_allclose(a.audio, b.audio, rtol=0, atol=1e-12)
    for k in probes:
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12, err_msg=k)
    assert np.all(np.isfinite(a.audio))


@pytest.mark.parametrize("path", PATCHES, ids=[p.stem for p in PATCHES])
def test_renders_headless_and_finite(path):
    r = render(load(path), 1.0)
    assert r.audio.shape[0] == int(r.rate)
    assert np.all(np.isfinite(r.audio))
    assert np.max(np.abs(r.audio)) > 1e-6, "silent patch"


def _ks_loop_delay(patch):
    # loop: delay line + the lowpass's group delay (symmetric FIR: (taps − 1)/2)
    taps = len(patch.blocks["damp"].values["coeffs"])
    return patch.blocks["loop"].values["length"] + (taps - 1) / 2


def test_karplus_strong_pitch(patches_dir):
    patch = load(patches_dir / "karplus_strong.yaml")
    expected = patch.rate / _ks_loop_delay(patch)
    assert expected == pytest.approx(441.0)
    y = render(patch, 1.0).audio[:, 0]
    f0 = estimate_f0(y, patch.rate)
    assert abs(f0 / expected - 1) < 0.005, f0


@pytest.mark.parametrize("length", [99, 150, 60])
def test_karplus_strong_pitch_follows_length(patches_dir, length):
    patch = load(patches_dir / "karplus_strong.yaml", overrides=[f"loop.length={length}"])
    y = render(patch, 1.0).audio[:, 0]
    expected = patch.rate / _ks_loop_delay(patch)
    assert abs(estimate_f0(y, patch.rate) / expected - 1) < 0.005


@pytest.mark.parametrize("interp", ["linear", "allpass"])
def test_feedback_comb_pitch(patches_dir, interp):
    patch = load(patches_dir / "feedback_comb.yaml", overrides=[f"line.interpolation={interp}"])
    expected = patch.rate / patch.blocks["line"].values["length"]
    assert expected == pytest.approx(400.0)
    y = render(patch, 1.0).audio[:, 0]
    assert abs(estimate_f0(y, patch.rate) / expected - 1) < 0.005


def test_feedback_comb_decay(patches_dir):
    """y[n] = x[n] + g y[n − M]: each round trip multiplies by g, so T60 = −3·M/(fs·log10 g).

    With the allpass interpolator (flat magnitude); linear interpolation also low-passes the
    loop, so its high partials die sooner and the envelope falls faster than this bound."""
    patch = load(patches_dir / "feedback_comb.yaml", overrides=["line.interpolation=allpass"])
    y = render(patch, 2.0).audio[:, 0]
    m, g = 110.25, 0.98
    period = int(round(m))
    frames = np.abs(y[: len(y) // period * period]).reshape(-1, period).max(axis=1)
    t = (np.arange(len(frames)) * period) / patch.rate
    slope = np.polyfit(t[2:], 20 * np.log10(frames[2:]), 1)[0]
    t60 = -60.0 / slope
    assert t60 == pytest.approx(-3 * m / (patch.rate * np.log10(g)), rel=0.03)
