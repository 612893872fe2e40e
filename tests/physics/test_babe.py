"""Seed 001: the Fig. 6 instrument of "The Babe is Sleeping" and the microphone as force-feedback
source, rendered headless with their simulated devices.

patches/babe_is_sleeping.yaml: two plates held at one cell with a free rim and a string; noise
swelled by a pedal; the plates' masses on two joystick axes. What is measured here:
- each plate's spectrum while the pedal is held: the largest peak is the plate's lowest mode
  (predicted from the lattice's stiffness matrix) and it stands clear of every other peak;
  the peaks above it are not at integer multiples of it (inharmonic, cymbal-like);
- the pedal gates the excitation: exact silence before the first press, sound while held, the
  free decay at the cells' rate γ/2m after release, sound again at the next press;
- moving a mass axis moves that plate's pitch by √(m_before/m_after): down for heavier;
- the mics are panned: each plate's lowest mode is louder on its own side.
patches/force_feedback_mic.yaml: the force sent to the joystick is the slider's gain times the
envelope of the microphone on the string, its envelope follows the sound's, and what reaches the
hand stays within the device's max_force (clipped where the patch asks for more).
"""
import pathlib

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from hapticgraph import load, render
from hapticgraph.devices import open_drivers
from hapticgraph.blocks.massspring import Network

PATCHES = pathlib.Path(__file__).resolve().parents[2] / "patches"
BABE = PATCHES / "babe_is_sleeping.yaml"
FF = PATCHES / "force_feedback_mic.yaml"

SILENT_UNTIL = 0.03             # s: the pedal is first pressed here (see the patch's script)
SWELL_1 = (0.5, 3.0)            # pedal held, stick centred: both plates at 1 g per cell
RELEASE = (3.02, 3.5)           # pedal up: the plates ring on
SWELL_2 = (4.0, 7.0)            # pedal held, jx = +1 (cym_a at 2 g), jy = −1 (cym_b at 0.5 g)
END = 7.5
PLATES = {  # plate: (its mic, its mass axis output, mass per cell in SWELL_1, in SWELL_2)
    "cym_a": ("mic_a", "mass_a", 0.001, 0.002),
    "cym_b": ("mic_b", "mass_b", 0.001, 0.0005),
}
# Welch estimates: 8192-sample segments (5.4 Hz bins) for peak heights, 32768 (1.35 Hz) for
# frequencies, refined by a parabola through the log spectrum around the peak.
HEIGHT_SEG, FREQ_SEG = 8192, 32768


@pytest.fixture(scope="module")
def babe():
    patch = load(BABE)
    probes = [f"{m}.in" for m in ("mic_a", "mic_b", "mic_s")] + ["mass_a.out", "mass_b.out", "noise_a.out"]
    return patch, render(patch, END, probes=probes)


def window(x, span, fs):
    return x[int(span[0] * fs):int(span[1] * fs)]


def spectrum(x, fs, seg):
    f, p = scipy.signal.welch(x, fs, nperseg=seg)
    return f, p


def peaks(f, p, count, fmin=0.0):
    """The `count` largest local maxima above fmin: (frequency, power), strongest first."""
    k, _ = scipy.signal.find_peaks(p)
    k = k[f[k] > fmin]
    k = k[np.argsort(-p[k])][:count]
    return [(f[i], p[i]) for i in k]


def refine(f, p, freq):
    """A peak's frequency from a parabola through the log power of its bin and the two beside."""
    i = int(np.argmin(np.abs(f - freq)))
    i = i - 1 + int(np.argmax(p[i - 1:i + 2]))
    a, b, c = np.log(p[i - 1:i + 2])
    return f[i] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])


def wiring(patch, plate):
    """The cells the plate is excited at and listened to (from the patch's connections)."""
    mic = PLATES[plate][0]
    exc = [c.dst.index for c in patch.connections if c.dst.block == plate and c.dst.port == "force"]
    lis = [c.src.index for c in patch.connections if c.src.block == plate and c.dst.block == mic]
    return exc[0], lis[0]


def modes(patch, plate, mass):
    """Angular eigenfrequencies and mass-normalised shapes of the plate at `mass` per cell, and
    the flat index of each cell among the free ones (the locked cell does not move)."""
    net = Network([patch.blocks[plate]], [], patch.rate)
    free = np.isfinite(net.masses())
    k = net.stiffness_matrix().toarray()[np.ix_(free, free)]
    w2, phi = scipy.linalg.eigh(k / mass)
    at = np.cumsum(free) - 1
    comp = net.components[0]
    return np.sqrt(w2), phi, (lambda index: int(at[comp.flat(index)]))


def predicted_margin(patch, plate, mass, fs, span):
    """dB by which the lowest mode's Welch peak (HEIGHT_SEG bins) should exceed every other peak:
    the displacement response to white force at the exciting cell, summed over all modes,
    |H(ω)|² = |Σ φ_k(exc)·φ_k(mic) / (ω_k² − ω² + iωγ/m)|², averaged over each analysis bin."""
    w, phi, at = modes(patch, plate, mass)
    exc, mic = wiring(patch, plate)
    gamma = patch.blocks[plate].values["damping"] / mass
    fine = np.arange(0.0, fs / 2, 0.05)
    om = 2 * np.pi * fine
    h = np.zeros(len(fine), complex)
    for k in range(len(w)):
        h += phi[at(exc), k] * phi[at(mic), k] / (w[k] ** 2 - om ** 2 + 1j * om * gamma)
    s = np.abs(h) ** 2
    width = fs / HEIGHT_SEG
    centres = np.arange(0.0, fs / 2, width)
    binned = np.array([s[(fine >= c - width / 2) & (fine < c + width / 2)].mean() for c in centres])
    (f0, p0), (_, p1) = peaks(centres, binned, 2)
    return 10 * np.log10(p0 / p1), f0


@pytest.mark.parametrize("plate", PLATES)
@pytest.mark.parametrize("swell", [1, 2])
def test_plate_has_a_dominant_low_mode(babe, plate, swell):
    """The largest peak is the plate's lowest mode, within 0.3 % of the eigenvalue (the half-step
    scheme's frequency warping is (ω·dt)²/24 ≈ 2e-5 here), and it exceeds every other peak of the
    spectrum by at least MARGIN dB.

    MARGIN: the modal prediction at this resolution is 13.5 … 14.0 dB (asserted ≥ 12 below, the
    design). A noise-driven Welch peak wanders: each resonance (decay time 2m/γ = 0.1 … 0.4 s)
    gives about window/τ ≈ 10 independent looks, a spread of 4.3/√10 ≈ 1.4 dB per peak; the
    largest of some 40 competing partials then sits ≈ 2.5 spreads high and the lowest mode may sit
    one spread low, so 14 − 3.5 − 1.4 ≈ 9 dB is what a bad seed still shows. Over other seeds of
    the same patch the measured margin ranged 8.5 … 15.6 dB. 8 dB: a component that much above
    every other is heard as the note of the cymbal.
    """
    patch, r = babe
    fs = r.rate
    mic, _, m1, m2 = PLATES[plate]
    mass = m1 if swell == 1 else m2
    span = SWELL_1 if swell == 1 else SWELL_2
    x = window(r.probes[f"{mic}.in"], span, fs)
    w, _, _ = modes(patch, plate, mass)
    f_lowest = w[0] / (2 * np.pi)
    margin, f_pred = predicted_margin(patch, plate, mass, fs, span)
    assert margin >= 12.0, f"the design: the lowest mode {margin:.1f} dB over the rest"
    assert abs(f_pred - f_lowest) < fs / HEIGHT_SEG
    f, p = spectrum(x, fs, HEIGHT_SEG)
    (fa, pa), (fb, pb) = peaks(f, p, 2)
    assert abs(fa - f_lowest) < fs / HEIGHT_SEG, (fa, f_lowest)
    measured = 10 * np.log10(pa / pb)
    assert measured >= 8.0, f"lowest mode only {measured:.1f} dB above the peak at {fb:.0f} Hz"
    f, p = spectrum(x, fs, FREQ_SEG)
    assert refine(f, p, f_lowest) == pytest.approx(f_lowest, rel=0.003)


@pytest.mark.parametrize("plate", PLATES)
def test_plate_partials_are_inharmonic(babe, plate):
    """The 8 strongest peaks above 1.5·f1: ratio r = f/f1 and its distance d to the nearest
    integer. A harmonic tone has every d below 0.01 (our frequency error, 1.35 Hz bins refined,
    is ≈ 0.3 Hz, d ± 0.003); for ratios spread at random d is 0.25 on average. Required: the
    median d above 0.1 and at most 2 of the 8 within 0.03 of an integer."""
    patch, r = babe
    fs = r.rate
    x = window(r.probes[f"{PLATES[plate][0]}.in"], SWELL_1, fs)
    f, p = spectrum(x, fs, FREQ_SEG)
    f1 = refine(f, p, peaks(f, p, 1)[0][0])
    found = peaks(f, p, 8, fmin=1.5 * f1)
    ratios = np.array([refine(f, p, fk) for fk, _ in found]) / f1
    d = np.abs(ratios - np.round(ratios))
    assert np.median(d) > 0.1, ratios
    assert np.sum(d < 0.03) <= 2, ratios


def test_pedal_gates_the_excitation(babe):
    patch, r = babe
    fs = r.rate
    before = r.audio[: int(SILENT_UNTIL * fs)]
    assert np.all(before == 0.0), "pedal up: the noise amplitude is exactly 0, so nothing moves"
    assert np.all(r.probes["noise_a.out"][: int(SILENT_UNTIL * fs)] == 0.0)
    held = window(r.audio, SWELL_1, fs)
    assert np.sqrt(np.mean(held ** 2)) > 0.03, "pedal down: an audible swell"
    assert np.max(np.abs(r.audio)) < 1.0, "no clipping"
    # released: the noise stops exactly; each plate rings on and dies at γ/2m per second
    # (every mode of a plate decays alike, viscous damping to ground)
    for plate, (mic, _, mass, _) in PLATES.items():
        x = window(r.probes[f"{mic}.in"], (RELEASE[0] + 0.03, RELEASE[1] - 0.03), fs)
        frame = int(0.02 * fs)
        rms = np.sqrt(np.mean(x[: len(x) // frame * frame].reshape(-1, frame) ** 2, axis=1))
        t = np.arange(len(rms)) * frame / fs
        rate = np.polyfit(t, np.log(rms), 1)[0]
        sigma = patch.blocks[plate].values["damping"] / (2 * mass)
        assert rate == pytest.approx(-sigma, rel=0.15), plate
        # pressed again: the plate swells again, far above its dying tail
        quiet = window(r.probes[f"{mic}.in"], (RELEASE[1] - 0.05, RELEASE[1]), fs)
        again = window(r.probes[f"{mic}.in"], (RELEASE[1] + 0.2, RELEASE[1] + 0.3), fs)
        assert np.sqrt(np.mean(again ** 2)) > 5 * np.sqrt(np.mean(quiet ** 2)), plate


@pytest.mark.parametrize("plate", PLATES)
def test_mass_axis_moves_the_pitch(babe, plate):
    """f ∝ 1/√m for every mode of a lattice: the lowest mode moves by √(m1/m2), down when the axis
    makes the plate heavier (cym_a, jx → +1) and up when lighter (cym_b, jy → −1)."""
    patch, r = babe
    fs = r.rate
    mic, axis, m1, m2 = PLATES[plate]
    assert window(r.probes[f"{axis}.out"], SWELL_1, fs) == pytest.approx(m1, rel=1e-12)
    assert window(r.probes[f"{axis}.out"], SWELL_2, fs) == pytest.approx(m2, rel=1e-12)
    f_at = []
    for span in (SWELL_1, SWELL_2):
        f, p = spectrum(window(r.probes[f"{mic}.in"], span, fs), fs, FREQ_SEG)
        f_at.append(refine(f, p, peaks(f, p, 1)[0][0]))
    assert f_at[1] / f_at[0] == pytest.approx(np.sqrt(m1 / m2), rel=0.005)
    assert (f_at[1] < f_at[0]) == (m2 > m1)


def test_mics_are_panned(babe):
    """mic_a is panned left (−0.6), mic_b right (+0.6): each plate's lowest mode is louder on its
    own side (cos²θ/sin²θ = 9.8 dB for the mic alone; the other mics add a little there)."""
    patch, r = babe
    fs = r.rate
    spectra = [spectrum(window(r.audio[:, ch], SWELL_1, fs), fs, HEIGHT_SEG) for ch in (0, 1)]
    for plate, side in (("cym_a", 0), ("cym_b", 1)):
        f, p = spectrum(window(r.probes[f"{PLATES[plate][0]}.in"], SWELL_1, fs), fs, HEIGHT_SEG)
        k = int(np.argmax(p))
        own, other = spectra[side][1][k], spectra[1 - side][1][k]
        assert 10 * np.log10(own / other) > 6.0, plate


# -- the microphone as force-feedback source ---------------------------------------------------

@pytest.fixture(scope="module")
def feedback():
    patch = load(FF)
    drivers = open_drivers(patch)
    probes = ["mic1.left", "env.out", "amount.out", "feel.out", "joy.force"]
    r = render(patch, 1.6, probes=probes, drivers=drivers)
    return patch, r, drivers["joy"]


def test_force_is_the_scaled_mic_envelope(feedback):
    patch, r, _ = feedback
    env = patch.blocks["env"].values
    fs = r.rate
    g_up, g_down = np.exp(-1 / (env["attack"] * fs)), np.exp(-1 / (env["release"] * fs))
    mic = r.probes["mic1.left"]
    level, expect = 0.0, np.empty_like(mic)
    for n, a in enumerate(np.abs(mic)):      # the envelope block's equation, sample by sample
        g = g_up if a > level else g_down
        level = g * level + (1 - g) * a
        expect[n] = level
    np.testing.assert_allclose(r.probes["env.out"], expect, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.probes["feel.out"], r.probes["amount.out"] * expect, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.probes["joy.force"], r.probes["feel.out"])


def test_force_follows_the_sound(feedback):
    """Frame by frame (5 ms), the force per unit of slider gain tracks the mic's peak amplitude:
    zero before the first pluck, rising with each pluck, dying with the string."""
    patch, r, _ = feedback
    fs = r.rate
    frame = int(0.005 * fs)
    n = len(r.probes["mic1.left"]) // frame * frame
    amp = np.abs(r.probes["mic1.left"][:n]).reshape(-1, frame).max(axis=1)
    per_gain = (r.probes["feel.out"][:n] / np.maximum(r.probes["amount.out"][:n], 1e-12)).reshape(-1, frame).mean(axis=1)
    assert np.all(per_gain[: int(0.1 * fs) // frame] == 0.0)
    assert np.corrcoef(amp, per_gain)[0, 1] > 0.95
    for pluck in (0.1, 0.6, 1.1):
        k = int(pluck * fs) // frame
        assert per_gain[k + 3] > 1.5 * per_gain[k - 1], f"the pluck at {pluck} s is felt"


def test_force_stays_within_max_force(feedback):
    patch, r, joy = feedback
    fs = r.rate
    limit = patch.devices["joy"]["max_force"]
    sent = joy.force_sent()
    force = r.probes["feel.out"]
    assert len(sent) == len(force)
    assert np.max(np.abs(sent)) <= limit
    # the first two notes (slider at 0.5) stay inside the limit by design and are felt;
    # the last one (slider at 1) asks for more and the hand receives exactly the limit
    first = force[: int(1.0 * fs)]
    assert 0.25 * limit < np.max(np.abs(first)) <= limit
    np.testing.assert_array_equal(sent[: int(1.0 * fs)], first)
    assert np.max(force) > limit
    np.testing.assert_allclose(sent, np.clip(force, -limit, limit), rtol=0, atol=0)
