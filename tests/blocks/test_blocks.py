"""Hand-computed sequences for each block of the foundation, through both engines."""
import math

import numpy as np
import pytest

from hapticgraph.blocks.excitation import Noise
from hapticgraph import render
from hapticgraph.graph.patch import load


def run(write_patch, text, seconds, probes, engine="compiled", rate=None):
    patch = load(write_patch(text))
    n = seconds if isinstance(seconds, float) else seconds / patch.rate
    return render(patch, n, probes=probes, engine=engine)


def both(write_patch, text, samples, probes):
    """Render `samples` samples with both engines, check they agree, return the compiled probes."""
    patch = load(write_patch(text))
    seconds = samples / patch.rate
    a = render(patch, seconds, probes=probes, engine="compiled")
    b = render(patch, seconds, probes=probes, engine="python")
    for k in probes:
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12)
    return a.probes


IMPULSE = "{type: pluck, time: 0.0, force: 1.0, duration: 0.0000227}"   # 1 sample at 44.1 kHz


def test_impulse_source_is_one_sample():
    p = None
    # duration·fs rounds to 1 sample: sin(π/2) = 1 at n = 0, then zeros
    import hapticgraph.blocks.excitation as ex
    assert ex.Pluck.output(0, 1, 0.0, 1.0, -1e18) == pytest.approx(1.0)
    assert ex.Pluck.output(1, 1, 0.0, 1.0, -1e18) == 0.0
    assert p is None


@pytest.mark.parametrize("length", [1, 5, 17])
def test_integer_delay(write_patch, length):
    text = f"""
    hapticgraph: 1
    blocks:
      imp: {IMPULSE}
      d: {{type: delay, length: {length}}}
    connect: [imp.out -> d.in]
    """
    y = both(write_patch, text, 40, ["d.out"])["d.out"]
    expect = np.zeros(40)
    expect[length] = 1.0
    np.testing.assert_array_equal(y, expect)


def test_fractional_delay_linear_taps(write_patch):
    text = f"""
    hapticgraph: 1
    blocks:
      imp: {IMPULSE}
      d: {{type: delay, length: 3.25}}
    connect: [imp.out -> d.in]
    """
    y = both(write_patch, text, 10, ["d.out"])["d.out"]
    expect = np.zeros(10)
    expect[3], expect[4] = 0.75, 0.25
    np.testing.assert_allclose(y, expect, atol=1e-15)


def _group_delay(h, w):
    """Group delay of an impulse response at angular frequency w (rad/sample), numerically."""
    n = np.arange(len(h))
    H = np.sum(h * np.exp(-1j * w * n))
    dH = np.sum(-1j * n * h * np.exp(-1j * w * n))
    return float(np.real(1j * dH / H))


@pytest.mark.parametrize("interp", ["linear", "allpass"])
@pytest.mark.parametrize("length", [2.0, 7.3, 12.5, 20.8])
def test_fractional_delay_group_delay(write_patch, interp, length):
    """At low frequency both interpolators delay by `length` (to 1e-3 samples at 0.01·fs)."""
    text = f"""
    hapticgraph: 1
    blocks:
      imp: {IMPULSE}
      d: {{type: delay, length: {length}, interpolation: {interp}}}
    connect: [imp.out -> d.in]
    """
    h = both(write_patch, text, 4096, ["d.out"])["d.out"]
    for w in (1e-3, 2 * math.pi * 0.01):
        assert _group_delay(h, w) == pytest.approx(length, abs=2e-3)
    if interp == "allpass":
        # allpass: flat magnitude at every frequency
        H = np.abs(np.fft.rfft(h))
        np.testing.assert_allclose(H, 1.0, atol=1e-6)


def test_lowpass_taps_and_gain(write_patch):
    text = f"""
    hapticgraph: 1
    blocks:
      imp: {IMPULSE}
      f: {{type: lowpass, coeffs: [0.1, 0.2, 0.3, 0.4], gain: -2.0}}
    connect: [imp.out -> f.in]
    """
    y = both(write_patch, text, 6, ["f.out"])["f.out"]
    np.testing.assert_allclose(y, [-0.2, -0.4, -0.6, -0.8, 0.0, 0.0], atol=1e-15)


def test_gain_constant_sum(write_patch):
    text = """
    hapticgraph: 1
    blocks:
      a: {type: constant, value: 3.0}
      b: {type: constant, value: 0.5}
      g: {type: gain, gain: -2.0}
      s: {type: sum}
    connect:
      - a.out -> g.in
      - g.out -> s.in
      - a.out -> s.in
      - b.out -> s.minus
    """
    p = both(write_patch, text, 3, ["g.out", "s.out"])
    np.testing.assert_array_equal(p["g.out"], [-6.0] * 3)
    np.testing.assert_array_equal(p["s.out"], [-6.0 + 3.0 - 0.5] * 3)


def test_scale_linear_exponential_clip():
    from hapticgraph.blocks.control import Scale
    P = Scale.param_tuple()
    lin = Scale.derive(P(in_range=(0.0, 2.0), out_range=(10.0, 20.0), curve="linear", clip=True), 44100.0)
    assert Scale.output(1.0, **lin) == pytest.approx(15.0)
    assert Scale.output(5.0, **lin) == pytest.approx(20.0)
    assert Scale.output(-1.0, **lin) == pytest.approx(10.0)
    ex = Scale.derive(P(in_range=(0.0, 1.0), out_range=(100.0, 10000.0), curve="exponential", clip=False), 44100.0)
    assert Scale.output(0.5, **ex) == pytest.approx(1000.0)
    assert Scale.output(2.0, **ex) == pytest.approx(1e6)


def test_sample_hold_suppresses_then_jumps(write_patch):
    text = """
    hapticgraph: 1
    rate: 1000
    blocks:
      ramp: {type: wavetable, shape: sawtooth, frequency: 1.0, amplitude: 1.0, bandlimited: false}
      hold: {type: wavetable, shape: square, frequency: 100.0, amplitude: 1.0, bandlimited: false}
      sh: {type: sample_hold}
    connect:
      - ramp.out -> sh.in
      - hold.out -> sh.hold
    """
    p = both(write_patch, text, 30, ["ramp.out", "hold.out", "sh.out"])
    x, h, y = p["ramp.out"], p["hold.out"], p["sh.out"]
    prev = 0.0
    for n in range(30):
        expect = prev if h[n] > 0.5 else x[n]
        assert y[n] == expect
        prev = y[n]
    assert h[0] > 0.5 and y[0] == 0.0          # held from the start
    held = [n for n in range(1, 30) if h[n] > 0.5 and y[n] != x[n]]
    released = [n for n in range(1, 30) if h[n] <= 0.5 and h[n - 1] > 0.5]
    assert held and released and all(y[n] == x[n] for n in released)


def test_envelope_attack_release():
    from hapticgraph.blocks.control import Envelope
    P = Envelope.param_tuple()
    c = Envelope.derive(P(attack=0.001, release=0.01), 1000.0)
    assert c["g_attack"] == pytest.approx(math.exp(-1.0))
    y = Envelope.output(-1.0, 0.0, **c)
    assert y == pytest.approx(1 - math.exp(-1.0))
    assert Envelope.output(0.0, 1.0, **c) == pytest.approx(math.exp(-0.1))


def test_pluck_half_sine_and_trigger(write_patch):
    text = """
    hapticgraph: 1
    rate: 1000
    blocks:
      trig: {type: wavetable, shape: square, frequency: 50.0, amplitude: 1.0, phase: 0.5, bandlimited: false}
      p: {type: pluck, time: 0.002, force: 2.0, duration: 0.004}
    connect: [trig.out -> p.trigger]
    """
    y = both(write_patch, text, 20, ["p.out"])["p.out"]
    pulse = [2.0 * math.sin(math.pi * (k + 0.5) / 4) for k in range(4)]
    np.testing.assert_allclose(y[2:6], pulse, atol=1e-12)
    # the square rises at n = 10 (phase 0.5 start, 20 samples a period), the pulse starts at n = 11
    np.testing.assert_allclose(y[11:15], pulse, atol=1e-12)
    assert y[6:11].tolist() == [0.0] * 5


@pytest.mark.parametrize("shape", ["sine", "square", "triangle", "sawtooth"])
def test_wavetable_shapes(write_patch, shape):
    text = f"""
    hapticgraph: 1
    rate: 48000
    blocks:
      w: {{type: wavetable, shape: {shape}, frequency: 1000.0, amplitude: 0.5, bandlimited: false}}
    connect: []
    """
    y = both(write_patch, text, 48, ["w.out"])["w.out"]
    ph, acc = np.zeros(48), 0.0
    for n in range(48):       # the phase accumulates exactly as the block does it
        ph[n] = acc
        acc += 1000.0 / 48000.0
        acc -= math.floor(acc)
    expect = {"sine": np.sin(2 * np.pi * ph), "square": np.where(ph < 0.5, 1.0, -1.0),
              "triangle": 1 - 2 * np.abs(2 * ((ph + 0.25) % 1.0) - 1),
              "sawtooth": 2 * ph - 1}[shape]
    np.testing.assert_allclose(y, 0.5 * expect, atol=1e-9)


@pytest.mark.parametrize("shape", ["sawtooth", "square"])
def test_bandlimited_shapes_alias_less(write_patch, shape):
    f0 = 2489.0
    def spectrum(bl):
        text = f"""
        hapticgraph: 1
        rate: 44100
        blocks:
          w: {{type: wavetable, shape: {shape}, frequency: {f0}, bandlimited: {str(bl).lower()}}}
        connect: []
        """
        y = run(write_patch, text, 1.0, ["w.out"]).probes["w.out"]
        return np.abs(np.fft.rfft(y * np.blackman(len(y)))) ** 2
    naive, blep = spectrum(False), spectrum(True)
    f = np.fft.rfftfreq(44100, 1 / 44100)
    harmonic = np.zeros_like(f, dtype=bool)
    for k in range(1, int(22050 // f0) + 1):
        harmonic |= np.abs(f - k * f0) < 30
    alias = ~harmonic & (f > 50)
    # PolyBLEP removes most of the folded energy: at least 10 dB less than the naive shape
    assert blep[alias].sum() < 0.1 * naive[alias].sum()


def test_noise_is_seeded_and_uniform(write_patch):
    text = """
    hapticgraph: 1
    blocks:
      a: {type: noise, seed: 11}
      b: {type: noise, seed: 11}
      c: {type: noise, seed: 12}
    connect: []
    """
    p = run(write_patch, text, 1.0, ["a.out", "b.out", "c.out"]).probes
    np.testing.assert_array_equal(p["a.out"], p["b.out"])
    assert not np.array_equal(p["a.out"], p["c.out"])
    y = p["a.out"]
    assert y.min() >= -1.0 and y.max() <= 1.0
    assert abs(y.mean()) < 0.02 and y.var() == pytest.approx(1 / 3, rel=0.03)
    # white: lag-1 autocorrelation is small
    assert abs(np.corrcoef(y[:-1], y[1:])[0, 1]) < 0.02
    short = both(write_patch, text, 300, ["a.out"])["a.out"]
    np.testing.assert_array_equal(short, y[:300])
    assert Noise.update(1.0, 1.0) == (40014.0, 40692.0)


def test_mic_constant_power_pan(write_patch):
    text = """
    hapticgraph: 1
    blocks:
      one: {type: constant, value: 1.0}
      m: {type: mic, gain: 2.0, pan: 0.5}
      out: {type: audio_out}
    connect:
      - one.out -> m.in
      - m.left -> out.left
      - m.right -> out.right
    """
    patch = load(write_patch(text))
    r = render(patch, 4 / 44100)
    theta = 1.5 * math.pi / 4
    np.testing.assert_allclose(r.audio[0], [2 * math.cos(theta), 2 * math.sin(theta)])
    assert np.sum(r.audio[0] ** 2) == pytest.approx(4.0)


def test_audio_out_channels(write_patch):
    text = """
    hapticgraph: 1
    blocks:
      one: {type: constant, value: 1.0}
      out: {type: audio_out, channels: 3}
    connect: [one.out -> out.ch2, one.out -> out.ch2]
    """
    r = render(load(write_patch(text)), 2 / 44100)
    np.testing.assert_array_equal(r.audio, [[0.0, 0.0, 2.0]] * 2)
