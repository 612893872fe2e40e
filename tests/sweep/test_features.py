"""Each feature against a signal whose answer is known in closed form (issue 23, item 6)."""
import math

import numpy as np
import pytest

from hapticgraph.sweeps import features

RATE = 44100.0


def _time(seconds):
    return np.arange(int(seconds * RATE)) / RATE


@pytest.mark.parametrize("freq", [82.41, 440.0, 1234.5])
def test_f0_of_a_sine(freq):
    x = 0.3 * np.sin(2 * math.pi * freq * _time(0.5))
    assert features.f0(x, RATE) == pytest.approx(freq, rel=1e-3)


def test_f0_of_a_harmonic_tone_is_its_fundamental_not_its_loudest_partial():
    t = _time(0.5)
    x = 0.2 * np.sin(2 * math.pi * 220 * t) + 0.8 * np.sin(2 * math.pi * 440 * t) + 0.5 * np.sin(2 * math.pi * 660 * t)
    assert features.f0(np.column_stack([x, x]), RATE) == pytest.approx(220.0, rel=1e-3)


def test_f0_of_silence_and_of_noise_is_nan():
    assert math.isnan(features.f0(np.zeros(4096), RATE))
    assert math.isnan(features.f0(np.random.default_rng(1).standard_normal(22050), RATE))


@pytest.mark.parametrize("seconds", [0.3, 1.5])
def test_t60_of_a_decaying_exponential(seconds):
    t = _time(1.0)
    tau = seconds / (3 * math.log(10))       # amplitude e^(−t/τ) falls 60 dB in T60 = 3·ln(10)·τ
    x = np.sin(2 * math.pi * 1000 * t) * np.exp(-t / tau)
    assert features.t60(x, RATE) == pytest.approx(seconds, rel=0.02)
    noise = np.random.default_rng(2).standard_normal(len(t)) * np.exp(-t / tau)
    assert features.t60(noise, RATE) == pytest.approx(seconds, rel=0.05)


def test_t60_of_a_steady_tone_is_infinite():
    assert features.t60(np.sin(2 * math.pi * 500 * _time(0.5)), RATE) == math.inf


def test_centroid_of_one_sine_and_of_two():
    t = _time(0.5)
    assert features.centroid(np.sin(2 * math.pi * 1000 * t), RATE) == pytest.approx(1000, rel=5e-3)
    both = np.sin(2 * math.pi * 500 * t) + np.sin(2 * math.pi * 3500 * t)
    assert features.centroid(both, RATE) == pytest.approx(2000, rel=5e-3)


def test_rms_and_peak_of_a_sine():
    x = 0.5 * np.sin(2 * math.pi * 100 * _time(1.0))
    stereo = np.column_stack([x, 2 * x])
    assert features.rms(x, RATE) == pytest.approx(0.5 / math.sqrt(2), rel=1e-6)
    assert features.peak(stereo, RATE) == pytest.approx(1.0, rel=1e-4)
    assert features.rms(stereo, RATE) == pytest.approx(math.sqrt((0.125 + 0.5) / 2), rel=1e-6)


@pytest.mark.parametrize("b", [0.0, 1e-4, 4e-4])
def test_inharmonicity_of_a_sum_of_stiff_string_partials(b):
    t = _time(1.0)
    f = 110.0
    x = sum(np.sin(2 * math.pi * n * f * math.sqrt(1 + b * n * n) * t) / n for n in range(1, 16))
    got = features.inharmonicity(x * np.exp(-t), RATE)
    assert got == pytest.approx(b, rel=0.02, abs=2e-6)


def test_a_plugin_registers_a_feature_and_compute_uses_it():
    features.register_feature("zero_crossings", lambda audio, rate: float(
        np.count_nonzero(np.diff(np.signbit(features.mono(audio))))))
    try:
        x = np.sin(2 * math.pi * 10 * _time(1.0) + 0.1)
        got = features.compute(["zero_crossings", "peak"], x, RATE)
        assert got["zero_crossings"] == 20 and got["peak"] == pytest.approx(1.0, rel=1e-4)
    finally:
        features._table.pop("zero_crossings")
    with pytest.raises(ValueError):
        features.register_feature("not a name", len)


def test_an_installed_package_adds_a_feature_through_the_entry_point_group(tmp_path, monkeypatch):
    dist = tmp_path / "hg_feature_demo-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: hg-feature-demo\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[hapticgraph.features]\nloudness = hg_feature_demo:loudness\n")
    (tmp_path / "hg_feature_demo.py").write_text("def loudness(audio, rate):\n    return 42.0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(features, "_entry_points_read", [])
    try:
        table = features.feature_table()
        assert table["loudness"](np.zeros(4), RATE) == 42.0 and "f0" in table
    finally:
        features._table.pop("loudness", None)
