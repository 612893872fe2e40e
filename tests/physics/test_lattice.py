"""Seed 001 (Cymatic): mass-spring lattices against their closed-form physics.

The half-step (leapfrog) scheme turns each mode of x'' = −ω_c²x into the recurrence
x[n+1] − 2x[n] + x[n−1] = −dt²ω_c²x[n], so a mode sounds at f_d = (fs/π)·asin(ω_c/(2 fs)).
For a fixed-boundary lattice of N_a cells along each axis a (T: spring stiffness, m: mass per cell)

    ω_c(k_1 … k_d)² = 4T/m · Σ_a sin²(k_a·π/(2(N_a + 1))),   k_a = 1 … N_a,

(a fixed–free chain of L cells: ω_c = 2√(T/m)·sin((2k − 1)π/(2(2L + 1))); a free–free one:
2√(T/m)·sin(kπ/(2N)), k = 0 … N − 1). The tests measure the rendered spectra (lossless,
impulse-excited, Blackman-Harris window, 4× zero padding, parabolic interpolation on the log
magnitude, which resolves a lossless partial to far better than 1e-5), check `hapticgraph modes`
against them, and check energy conservation, topologies (locked, cut, free, joined), live mass,
the stability refusal and compiled == interpreter.
"""
import itertools
import math
import pathlib
import re

import numpy as np
import pytest

from hapticgraph import load, render
from hapticgraph.cli import main
from hapticgraph.graph import modes as modes_mod
from hapticgraph.graph.modes import discrete_frequency, modal_frequencies, network_modes

FS = 44100.0
PATCHES = pathlib.Path(__file__).resolve().parents[2] / "patches"
TOL = 0.002            # 0.2 %


# -- closed forms -------------------------------------------------------------------------------
def omega_fixed(T, m, shape):
    """Every ω_c of a fixed-boundary lattice, ascending."""
    axes = [np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1))) ** 2 for n in shape]
    total = sum(np.meshgrid(*axes, indexing="ij"))
    return np.sort(2 * np.sqrt(T / m) * np.sqrt(total.ravel()))


def mode_shapes_fixed(shape):
    """φ(ks, index): the separable sine shape of mode ks of a fixed lattice at a cell."""
    def phi(ks, index):
        return np.prod([math.sin(k * math.pi * (i + 1) / (n + 1)) for k, i, n in zip(ks, index, shape)])
    return phi


def fd(omega_c, fs=FS):
    return fs / math.pi * np.arcsin(np.asarray(omega_c) / (2 * fs))


def laplacian(shape, fixed=True):
    """K/T of a lattice (C order), built independently of graph.network: a Kronecker sum of 1-D
    chains (fixed: the ends tied to 0; free: not)."""
    def chain(n):
        k = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
        if not fixed:
            k[0, 0] = k[-1, -1] = 1.0
        return k
    total = np.zeros((math.prod(shape),) * 2)
    for a, n in enumerate(shape):
        parts = [np.eye(s) for s in shape]
        parts[a] = chain(n)
        term = parts[0]
        for p in parts[1:]:
            term = np.kron(term, p)
        total += term
    return total


# -- spectra ------------------------------------------------------------------------------------
def spectral_peaks(y, fs, floor_db=90.0, pad=4):
    """All local maxima of the Blackman-Harris spectrum within floor_db of the largest:
    (frequencies [Hz], levels [dB]), each refined by a parabola through the log magnitude."""
    from scipy.signal import get_window
    y = np.asarray(y, dtype=np.float64) - np.mean(y)
    w = get_window("blackmanharris", len(y), fftbins=False)
    n = 1 << int(np.ceil(np.log2(len(y) * pad)))
    db = 20 * np.log10(np.abs(np.fft.rfft(y * w, n)) + 1e-300)
    top = db.max()
    i = np.nonzero((db[1:-1] > db[:-2]) & (db[1:-1] >= db[2:]) & (db[1:-1] > top - floor_db))[0] + 1
    a, b, c = db[i - 1], db[i], db[i + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c)
    return (i + shift) * fs / n, b - 0.25 * (a - c) * shift


def nearest(peaks, f):
    return peaks[np.argmin(np.abs(peaks - f))]


def isolated(freqs, min_gap):
    """Mask of the entries of a sorted array at least min_gap [Hz] from both neighbours."""
    gaps = np.diff(freqs)
    left = np.concatenate([[np.inf], gaps])
    right = np.concatenate([gaps, [np.inf]])
    return (left >= min_gap) & (right >= min_gap)


def lattice_patch(shape, mass, tension, excite, probes=(), boundary="fixed", extra="", damping=0.0,
                  rate=FS, force=1.0, audio=False):
    """A patch text: one lattice `L`, an impulse (a one-sample pluck) into cell `excite`."""
    idx = lambda i: ", ".join(str(int(v)) for v in i)  # noqa: E731
    lines = ["hapticgraph: 1", f"rate: {rate:g}", "blocks:",
             f"  L: {{type: lattice, shape: [{idx(shape)}], mass: {mass!r}, tension: {tension!r}, "
             f"damping: {damping!r}, boundary: {boundary}{extra}}}",
             f"  hit: {{type: pluck, time: 0.0, force: {force!r}, duration: 1.0e-6}}"]
    conns = [f"  - hit.out -> L[{idx(excite)}].force"]
    if audio:
        lines += ["  mic: {type: mic, gain: 1.0}", "  out: {type: audio_out, channels: 2}"]
        conns += [f"  - L[{idx(probes[0])}].velocity -> mic.in", "  - mic.left -> out.left",
                  "  - mic.right -> out.right"]
    return "\n".join(lines + ["connect:"] + conns) + "\n"


def cell_probe(index, port="position"):
    return f"L[{', '.join(str(int(i)) for i in index)}].{port}"


# -- the discrete-time correction and the closed forms ------------------------------------------
def test_discrete_time_correction_of_one_cell(write_patch):
    """One fixed cell (Σk = 2T): ω_c = √(2T/m) chosen near the load-time limit dt²·Σk/m < 2
    (ω_c·dt/2 = 0.7), where f_d = (fs/π)·asin(0.7) is 11 % above ω_c/2π: the rendered tone is
    f_d, not ω_c/2π."""
    m = 1e-3
    T = (0.7 * 2 * FS) ** 2 * m / 2
    path = write_patch(lattice_patch([1], m, T, [0]))
    y = render(load(path), 0.5, probes=["L[0].position"]).probes["L[0].position"]
    f = nearest(spectral_peaks(y, FS)[0], FS / math.pi * math.asin(0.7))
    wc = math.sqrt(2 * T / m)
    assert f == pytest.approx(FS / math.pi * math.asin(0.7), rel=1e-6)
    assert f == pytest.approx(float(discrete_frequency(wc, FS)), rel=1e-6)
    assert abs(f / (wc / (2 * math.pi)) - 1) > 0.10          # the uncorrected value is far off
    assert modal_frequencies(load(path))["L"] == [pytest.approx(f, rel=1e-6)]


def test_discrete_frequency_formula():
    """sin(ω_d·dt/2) = ω_c·dt/2 solves 2 − 2cos(ω_d dt) = dt²ω_c² (the leapfrog recurrence)."""
    dt = 1 / FS
    for wc in (10.0, 1000.0, 30000.0, 2 * FS * 0.999):
        wd = 2 * math.pi * float(discrete_frequency(wc, FS))
        assert 2 - 2 * math.cos(wd * dt) == pytest.approx(dt * dt * wc * wc, rel=1e-12)
    assert math.isnan(float(discrete_frequency(2.01 * FS, FS)))


@pytest.mark.parametrize("shape", [[36], [10, 12], [4, 6, 10], [3, 4, 2, 5]])
@pytest.mark.parametrize("dense", [True, False], ids=["dense", "shift-invert"])
def test_modes_match_the_closed_form(write_patch, shape, dense, monkeypatch):
    """`modal_frequencies` (both solvers) = the separable closed form + the correction, to 1e-9."""
    if not dense:       # the solver is chosen by cost (small networks go dense): force ARPACK
        plan = modes_mod.solver_plan
        monkeypatch.setattr(modes_mod, "DENSE_MAX", 0)
        monkeypatch.setattr(modes_mod, "solver_plan", lambda *args, **kw: ("shift-invert",) + plan(*args, **kw)[1:])
    m, T = 1e-3, 2e5
    path = write_patch(lattice_patch(shape, m, T, [0] * len(shape)))
    count = min(25, math.prod(shape) - 2)
    got = np.array(modal_frequencies(load(path), count=count)["L"])
    want = fd(omega_fixed(T, m, shape)[:count])
    np.testing.assert_allclose(got, want, rtol=1e-9)
    assert network_modes(load(path), count)[0].method == ("dense" if dense else "shift-invert")


def test_shift_invert_is_fast_on_thousands_of_cells(write_patch):
    """A 3-D block of 3360 cells and a free 2-D sheet of 2000: shift-invert, well under seconds,
    the free sheet's rigid mode reported as 0 Hz first."""
    import time
    text = """
    hapticgraph: 1
    rate: 44100
    blocks:
      b: {type: lattice, shape: [14, 15, 16], mass: 0.001, tension: 1000.0}
      f: {type: lattice, shape: [40, 50], mass: 0.001, tension: 1000.0, boundary: free}
    connect: []
    """
    patch = load(write_patch(text))
    start = time.perf_counter()
    nets = network_modes(patch, 12)
    assert time.perf_counter() - start < 10.0
    assert [n.method for n in nets] == ["shift-invert", "shift-invert"]
    np.testing.assert_allclose(nets[0].frequencies, fd(omega_fixed(1000.0, 1e-3, [14, 15, 16])[:12]), rtol=1e-9)
    free = sorted(2 * math.sqrt(1e6) * math.sqrt(math.sin(a * math.pi / 80) ** 2 + math.sin(b * math.pi / 100) ** 2)
                  for a in range(40) for b in range(50))[:12]
    assert nets[1].rigid == 1 and nets[1].frequencies[0] == 0.0
    np.testing.assert_allclose(nets[1].frequencies[1:], fd(free[1:]), rtol=1e-9)


# -- measured dispersion: 1-D, 2-D, 3-D ---------------------------------------------------------
CASES = {
    # shape, mass, tension, excited cell, probed cell, seconds, min gap between modes [Hz]
    "1d": ([36], 1e-3, 3e5, [5], [22], 1.0, 0.0),
    "2d": ([10, 12], 1e-3, 1.5e5, [1, 2], [6, 8], 2.0, 6.0),
    "3d": ([4, 6, 10], 1e-3, 1e5, [0, 1, 2], [2, 4, 6], 2.0, 6.0),
}


@pytest.fixture(scope="module")
def dispersion_runs(tmp_path_factory):
    out = {}
    folder = tmp_path_factory.mktemp("dispersion")
    for name, (shape, m, T, exc, probe, seconds, gap) in CASES.items():
        path = folder / f"{name}.yaml"
        path.write_text(lattice_patch(shape, m, T, exc))
        y = render(load(path), seconds, probes=[cell_probe(probe)]).probes[cell_probe(probe)]
        out[name] = (path, y)
    return out


def _expected_modes(shape, m, T, exc, probe):
    """(ω_c, expected amplitude ∝ |φ(exc)·φ(probe)|/ω) of every mode of a fixed lattice."""
    phi = mode_shapes_fixed(shape)
    rows = []
    for ks in itertools.product(*[range(1, n + 1) for n in shape]):
        w = 2 * math.sqrt(T / m) * math.sqrt(sum(math.sin(k * math.pi / (2 * (n + 1))) ** 2
                                                 for k, n in zip(ks, shape)))
        rows.append((w, abs(phi(ks, exc) * phi(ks, probe)) / w))
    rows.sort()
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


@pytest.mark.parametrize("name", list(CASES))
def test_measured_modes_follow_the_dispersion_relation(dispersion_runs, name):
    """Every clearly excited, resolvable mode of the rendered spectrum within 0.2 % of the closed
    form with the discrete-time correction (measured: ~1e-6); without the correction the high
    modes miss by more than 0.2 %, so the correction is what is being checked."""
    shape, m, T, exc, probe, seconds, gap = CASES[name]
    path, y = dispersion_runs[name]
    peaks, _ = spectral_peaks(y, FS)
    wc, amp = _expected_modes(shape, m, T, exc, probe)
    want = fd(wc)
    pick = (amp > 1e-3 * amp.max()) & isolated(want, gap)
    assert pick.sum() >= min(20, len(wc)), pick.sum()
    got = np.array([nearest(peaks, f) for f in want[pick]])
    err = got / want[pick] - 1
    print(f"\n{name} {shape}: {pick.sum()} modes {want[pick][0]:.1f} … {want[pick][-1]:.1f} Hz, "
          f"max |error| {np.max(np.abs(err)):.2e} (uncorrected: {np.max(np.abs(got / (wc[pick] / 2 / np.pi) - 1)):.2e})")
    assert np.max(np.abs(err)) < TOL
    assert np.max(np.abs(got / (wc[pick] / (2 * np.pi)) - 1)) > TOL     # the correction matters here
    # and `hapticgraph modes` predicts the same frequencies
    pred = np.array(modal_frequencies(load(path), count=len(wc) if len(wc) < 60 else 60)["L"])
    np.testing.assert_allclose(pred, want[:len(pred)], rtol=1e-9)


# -- `modes` against the rendered patches -------------------------------------------------------
@pytest.mark.parametrize("stem", ["cymatic_string", "cymatic_sheet", "cymatic_block", "hyper_4d",
                                  "string_drives_plate"])
def test_modes_match_the_rendered_patch(stem):
    """The lowest peaks of each patch's sound (its mics, damping included) are the modes `modes`
    predicts: each of the 5 lowest strong peaks (within 40 dB of the loudest) within 0.2 % of a
    predicted mode, and the predicted fundamental is one of them. (hyper_4d strikes again at
    0.8 s: only the ring of the first strike is analysed.)"""
    patch = load(PATCHES / f"{stem}.yaml")
    (net,) = network_modes(patch, 100)
    pred = np.array(net.frequencies)
    end = 0.79 if stem == "hyper_4d" else 3.0
    y = render(patch, end).audio[int(0.02 * FS):, 0]
    peaks, level = spectral_peaks(y, FS, floor_db=40.0)
    low = np.sort(peaks[peaks < pred[-1]])[:5]
    assert len(low) == 5
    err = np.array([nearest(pred, f) / f - 1 for f in low])
    print(f"\n{stem}: lowest peaks {np.round(low, 2)} Hz; predicted {np.round(pred[:6], 2)}; "
          f"max |error| {np.max(np.abs(err)):.1e}")
    assert np.max(np.abs(err)) < TOL
    assert abs(nearest(low, pred[0]) / pred[0] - 1) < TOL


def test_bowed_lattice_string_sounds_at_its_fundamental():
    """The bowed lattice string's Helmholtz pitch within 0.5 % of the predicted fundamental; under
    the bow the cell moves with the bow most of each period and flies back at ≈ −v_bow(1 − β)/β."""
    from analysis import estimate_f0
    patch = load(PATCHES / "bowed_lattice_string.yaml")
    f1 = modal_frequencies(patch, 1)["str"][0]
    assert f1 == pytest.approx(196.0, abs=0.05)
    v = render(patch, 2.0, probes=["str[9].velocity"]).probes["str[9].velocity"][int(1.5 * FS):]
    f0 = estimate_f0(v, FS, fmin=f1 / 1.5, fmax=f1 * 1.5)
    vb, beta = 0.5, 0.2
    print(f"\nbowed lattice string: f1 {f1:.3f} Hz, pitch {f0:.3f} Hz ({(f0 / f1 - 1) * 100:+.3f} %), "
          f"v {v.min():.3f} … {v.max():.3f} m/s, with the bow {np.mean(v > 0) * 100:.0f} % of the time")
    assert abs(f0 / f1 - 1) < 0.005
    assert v.min() == pytest.approx(-vb * (1 - beta) / beta, rel=0.05)
    assert 0.65 < np.mean(v > 0) < 0.85


# -- energy ------------------------------------------------------------------------------------
def modified_energy(x, mass, K, dt):
    """The leapfrog's conserved energy H_n = ½·Σ m·v[n+½]² + ½·x[n+1]ᵀ K x[n] (v[n+½] = (x[n+1] − x[n])/dt):
    H_n − H_{n−1} = ½(v₊ − v₋)ᵀM(v₊ + v₋) + ½x_nᵀK(x_{n+1} − x_{n−1}) = 0 exactly for the scheme."""
    v = np.diff(x, axis=0) / dt
    return 0.5 * np.sum(mass * v * v, axis=1) + 0.5 * np.einsum("ij,ij->i", x[1:] @ K, x[:-1])


STEPS = 1_000_000


@pytest.mark.parametrize("kind", ["sheet_stencil", "string_csr"])
def test_lossless_energy_is_conserved_over_a_million_steps(write_patch, kind):
    """Damping 0, one impulse, 10⁶ steps of the compiled kernel (the regular stencil, and the CSR
    path forced by a locked cell): the modified energy stays constant to roundoff, and the amplitude
    of every mode — the projection of x onto the eigenvectors of K/m, fitted from samples 1 and 2 —
    is the same at the end as at the start: nothing grows, nothing decays."""
    m = 1e-3
    if kind == "sheet_stencil":
        shape, extra, T, locked = [3, 4], "", 2e5, None
    else:
        shape, extra, T, locked = [10], ", lock: [[6]]", 3e5, (6,)
    cells = [c for c in itertools.product(*[range(n) for n in shape]) if c != locked]
    keep = [int(np.ravel_multi_index(c, shape)) for c in cells]
    K = (T * laplacian(shape))[np.ix_(keep, keep)]          # a locked cell leaves K (it stays at 0)
    path = write_patch(lattice_patch(shape, m, T, [1] + [2] * (len(shape) - 1), extra=extra, force=0.3))
    r = render(load(path), STEPS / FS, probes=[cell_probe(c) for c in cells])
    x = np.stack([r.probes[cell_probe(c)] for c in cells], axis=1)
    assert x.shape == (STEPS, len(cells)) and np.all(np.isfinite(x))
    h = modified_energy(x[1:], m, K, 1 / FS)         # from sample 1 on, the impulse is over
    drift = np.max(np.abs(h - h[0])) / h[0]
    lam, phi = np.linalg.eigh(K / m)
    wd = 2 * np.arcsin(np.sqrt(lam) / (2 * FS))       # per sample: 2 − 2cos(wd) = dt²λ
    q = x @ phi                                       # modal coordinates
    amp = np.sqrt(q[1] ** 2 + ((q[2] - q[1] * np.cos(wd)) / np.sin(wd)) ** 2)
    tail = np.max(np.abs(q[-STEPS // 10:]), axis=0)
    bound = np.abs(phi) @ amp                         # |x_i| ≤ Σ_k |φ_k(i)|·A_k
    excited = amp > 1e-6 * amp.max()
    ratio = tail[excited] / amp[excited]
    print(f"\n{kind}: energy {h[0]:.6e} J, max relative drift over {STEPS:,} steps {drift:.2e}; "
          f"excited modes' amplitudes, last tenth / start: {np.min(ratio):.6f} … {np.max(ratio):.6f}")
    assert drift < 1e-9
    np.testing.assert_allclose(tail, amp, rtol=1e-3, atol=1e-9 * amp.max())
    assert np.all(np.max(np.abs(x[1:]), axis=0) <= bound * (1 + 1e-9))


# -- topologies --------------------------------------------------------------------------------
def test_a_locked_cell_splits_a_string_into_two_independent_strings(write_patch):
    """A 24-cell fixed string with cell [9] locked: two fixed–fixed strings of 9 and 14 cells.
    `modes` gives the union of their closed forms; exciting the left half leaves the right half
    exactly at rest, and the left half rings at the 9-cell string's modes."""
    m, T = 1e-3, 2e5
    path = write_patch(lattice_patch([24], m, T, [2], extra=", lock: [[9]]"))
    union = np.sort(np.concatenate([omega_fixed(T, m, [9]), omega_fixed(T, m, [14])]))
    (net,) = network_modes(load(path), 23)
    assert net.cells == 23 and net.locked == 1
    np.testing.assert_allclose(net.frequencies, fd(union), rtol=1e-9)
    r = render(load(path), 1.0, probes=["L[6].position", "L[8].position", "L[10].position", "L[20].position"])
    assert np.max(np.abs(r.probes["L[6].position"])) > 1e-6 and np.max(np.abs(r.probes["L[8].position"])) > 1e-6
    for k in ("L[10].position", "L[20].position"):
        assert np.all(r.probes[k] == 0.0), k
    peaks, _ = spectral_peaks(r.probes["L[6].position"], FS)
    want = fd(omega_fixed(T, m, [9]))
    err = np.array([nearest(peaks, f) / f - 1 for f in want])
    assert np.max(np.abs(err)) < 1e-4, err


def test_a_cut_cell_leaves_two_fixed_free_strings(write_patch):
    """A 20-cell fixed string with cell [7] cut: the cells beside the cut lose a neighbour and no
    anchor replaces it, so it leaves two strings, 7 cells fixed–free and 12 cells free–fixed:
    ω = 2√(T/m)·sin((2k − 1)π/(2(2L + 1))) (odd 'quarter-wave' modes)."""
    m, T = 1e-3, 2e5
    path = write_patch(lattice_patch([20], m, T, [1], extra=", cut: [[7]]"))

    def fixed_free(L):
        return 2 * math.sqrt(T / m) * np.sin((2 * np.arange(1, L + 1) - 1) * np.pi / (2 * (2 * L + 1)))
    want = fd(np.sort(np.concatenate([fixed_free(7), fixed_free(12)])))
    (net,) = network_modes(load(path), 19)
    assert net.cells == 19
    np.testing.assert_allclose(net.frequencies, want, rtol=1e-9)
    # excite and listen where no mode of the 7-cell piece has a node: sin((2k − 1)π·j/15) ≠ 0
    # for j = i + 1 = 2 and 7 (the free end)
    r = render(load(path), 1.0, probes=["L[6].position", "L[8].position", "L[15].position"])
    assert np.all(r.probes["L[8].position"] == 0.0) and np.all(r.probes["L[15].position"] == 0.0)
    y = r.probes["L[6].position"]
    peaks, _ = spectral_peaks(y, FS)
    left = fd(fixed_free(7))
    err = np.array([nearest(peaks, f) / f - 1 for f in left])
    assert np.max(np.abs(err)) < 1e-4, err
    # the cut cell has no ports
    bad = write_patch(lattice_patch([20], m, T, [7], extra=", cut: [[7]]"), name="bad.yaml")
    assert main(["check", str(bad)]) == 2


def test_a_free_string_has_a_rigid_mode_reported_at_zero(write_patch, capsys):
    """boundary: free — nothing anchors the string: `modes` reports one 0 Hz rigid mode first, then
    2√(T/m)·sin(kπ/(2N)); the impulse sets the whole string drifting (its momentum is conserved)."""
    m, T, N = 1e-3, 2e5, 16
    path = write_patch(lattice_patch([N], m, T, [3], boundary="free"))
    (net,) = network_modes(load(path), 6)
    assert net.rigid == 1 and net.frequencies[0] == 0.0
    want = fd(2 * math.sqrt(T / m) * np.sin(np.arange(1, 6) * np.pi / (2 * N)))
    np.testing.assert_allclose(net.frequencies[1:], want, rtol=1e-9)
    probes = [f"L[{i}].velocity" for i in range(N)]
    r = render(load(path), 0.2, probes=probes + ["L[12].position"])
    momentum = m * np.sum([r.probes[p] for p in probes], axis=0)
    impulse = 1.0 / FS          # one sample of 1 N
    np.testing.assert_allclose(momentum[1:], impulse, rtol=1e-9)
    y = r.probes["L[12].position"]
    drift = np.polyfit(np.arange(len(y)) / FS, y, 1)[0]
    assert drift == pytest.approx(impulse / (N * m), rel=0.01)
    assert main(["modes", str(path), "--count", "3"]) == 0
    assert "rigid" in capsys.readouterr().out


def join_patch(join_tension):
    return f"""
hapticgraph: 1
rate: 44100
blocks:
  str:   {{type: lattice, shape: [12], mass: 0.001, tension: 50000.0}}
  plate: {{type: lattice, shape: [4, 5], mass: 0.001, tension: 20000.0}}
  join:  {{type: spring, a: "str[9]", b: "plate[1, 2]", tension: {join_tension}}}
  hit:   {{type: pluck, time: 0.0, force: 0.5, duration: 1.0e-6}}
connect:
  - hit.out -> str[3].force
"""


JOIN_CELLS = [f"str[{i}]" for i in range(12)] + [f"plate[{i}, {j}]" for i in range(4) for j in range(5)]


KJ = 20000.0          # the join's stiffness [N/m]


def join_stiffness(kj):
    """K of join_patch, built by hand: the two lattices' Laplacians and the join's 2×2 block."""
    K = np.zeros((32, 32))
    K[:12, :12] = 50000.0 * laplacian([12])
    K[12:, 12:] = 20000.0 * laplacian([4, 5])
    a, b = 9, 12 + 1 * 5 + 2
    K[np.ix_([a, b], [a, b])] += kj * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return K


def test_a_join_carries_energy_from_the_string_to_the_plate(write_patch):
    """A plucked string joined to a plate at rest (lossless): the plate stays exactly at rest until
    the disturbance reaches it through the join (the scheme moves it one cell per sample: from
    str[3] to str[9] and across, 7 samples), then it takes a good part of the energy (about 13 %
    on average over the second half second, the rest in the string and the join) while the network's modified energy (the join's spring included) stays constant; with the
    join's tension 0 the plate never moves."""
    m, kj = 1e-3, KJ
    probes = [f"{c}.position" for c in JOIN_CELLS]
    K = join_stiffness(kj)
    r = render(load(write_patch(join_patch(kj))), 1.0, probes=probes)
    x = np.stack([r.probes[p] for p in probes], axis=1)
    h = modified_energy(x[1:], m, K, 1 / FS)
    drift = np.max(np.abs(h - h[0])) / h[0]
    assert drift < 1e-10
    assert np.all(x[:8, 12:] == 0.0) and x[8, 12 + 7] != 0.0 and x[7, 9] != 0.0 and x[6, 9] == 0.0
    v = np.diff(x, axis=0) * FS
    plate = 0.5 * m * np.sum(v[:, 12:] ** 2, axis=1) + 0.5 * np.einsum("ij,ij->i", x[1:, 12:] @ K[12:, 12:],
                                                                          x[:-1, 12:])
    window = 441
    share = np.array([np.mean(plate[i:i + window]) / h[0] for i in range(0, len(plate) - window, window)])
    late = np.mean(plate[len(plate) // 2:]) / h[0]
    print(f"\njoin: energy drift {drift:.1e}; plate's share of the energy in 10 ms windows: first "
          f"{share[0]:.3f}, largest {share.max():.3f}; mean over 0.5 … 1 s {late:.3f}")
    assert share.max() > 0.1 and late > 0.08
    # no join tension: the plate is untouched
    r0 = render(load(write_patch(join_patch(0.0), name="j0.yaml")), 0.2, probes=probes)
    assert all(np.all(r0.probes[f"{c}.position"] == 0.0) for c in JOIN_CELLS[12:])
    assert np.max(np.abs(r0.probes["str[5].position"])) > 0


def test_join_modes_against_the_rendered_spectrum(write_patch):
    """The joined network is not separable (no closed form): `modes` equals the eigenvalues of the
    hand-built K (1e-9), and every mode clearly excited at str[3] and heard at plate[2, 3] and
    resolvable (≥ 6 Hz from its neighbours) is a peak of the rendered spectrum within 0.2 %."""
    m, kj = 1e-3, KJ
    path = write_patch(join_patch(kj))
    (net,) = network_modes(load(path), 32)
    assert net.name == "str + plate + join" and net.cells == 32
    lam, phi = np.linalg.eigh(join_stiffness(kj) / m)
    want = fd(np.sqrt(lam))
    np.testing.assert_allclose(net.frequencies, want, rtol=1e-9)
    probe = 12 + 2 * 5 + 3
    y = render(load(path), 2.0, probes=["plate[2, 3].position"]).probes["plate[2, 3].position"]
    peaks, _ = spectral_peaks(y, FS, floor_db=100.0)
    amp = np.abs(phi[3] * phi[probe]) / np.sqrt(lam)
    sel = (amp > 1e-2 * amp.max()) & isolated(want, 6.0)
    err = np.array([nearest(peaks, f) / f - 1 for f in want[sel]])
    print(f"\njoined network: {sel.sum()} modes {want[sel][0]:.1f} … {want[sel][-1]:.1f} Hz, "
          f"max |error| {np.max(np.abs(err)):.1e}")
    assert sel.sum() >= 10 and np.max(np.abs(err)) < TOL


# -- live mass -------------------------------------------------------------------------------
@pytest.mark.parametrize("extra", ["", ", lock: [[0]]"], ids=["stencil", "csr"])
def test_pitch_follows_a_live_mass(write_patch, extra):
    """A simulated device's `slider` axis wired to the lattice's `mass` input jumps from 1 g to 4 g
    at t = 1 s while the lossless string rings: the pitch falls by √(m2/m1) = 2 (to 0.5 %), each
    pitch matches the closed form at its mass, and `modes` (patch value) gives the first."""
    from analysis import spectral_peak
    T, m1, m2, N = 1e5, 0.001, 0.004, 30
    text = f"""
hapticgraph: 1
rate: 44100
devices:
  knob: {{driver: simulated, script: [{{t: 0.0, x: 0.0, slider: {m1}}}, {{t: 1.0, slider: {m1}}},
                                      {{t: 1.00001, slider: {m2}}}, {{t: 2.0, slider: {m2}}}]}}
blocks:
  dev:  {{type: haptic, device: knob}}
  L:    {{type: lattice, shape: [{N}], mass: {m1}, tension: {T}{extra}}}
  hit:  {{type: pluck, time: 0.0, force: 1.0, duration: 0.0005}}
connect:
  - dev.slider -> L.mass
  - hit.out -> L[4].force
"""
    path = write_patch(text)
    n = N - 1 if extra else N     # a locked end cell leaves a fixed string of N − 1 cells
    r = render(load(path), 2.0, probes=["L[12].position", "L.mass"])
    y, mass = r.probes["L[12].position"], r.probes["L.mass"]
    assert mass[int(0.5 * FS)] == m1 and mass[int(1.5 * FS)] == m2
    f_exp = [float(fd(omega_fixed(T, mm, [n])[0])) for mm in (m1, m2)]
    f1 = spectral_peak(y[int(0.05 * FS):int(0.99 * FS)], FS, f_exp[0] * 0.8, f_exp[0] * 1.2)
    f2 = spectral_peak(y[int(1.01 * FS):], FS, f_exp[1] * 0.8, f_exp[1] * 1.2)
    ratio = f1 / f2
    print(f"\nlive mass ({'CSR' if extra else 'stencil'}): f({m1} kg) = {f1:.3f} Hz (closed form "
          f"{f_exp[0]:.3f}), f({m2} kg) = {f2:.3f} Hz ({f_exp[1]:.3f}); ratio {ratio:.5f}, "
          f"√(m2/m1) = {math.sqrt(m2 / m1):.5f} ({(ratio / math.sqrt(m2 / m1) - 1) * 100:+.3f} %)")
    assert ratio == pytest.approx(math.sqrt(m2 / m1), rel=0.005)
    assert f1 == pytest.approx(f_exp[0], rel=TOL) and f2 == pytest.approx(f_exp[1], rel=TOL)
    net = network_modes(load(path), 1)[0]
    assert net.frequencies[0] == pytest.approx(f_exp[0], rel=1e-9)
    assert any("L.mass is driven by a connection" in note for note in net.notes)


@pytest.mark.parametrize("boundary", ["fixed", "free"])
def test_the_cube_stencil_moves_cells_as_the_csr_lists_do(write_patch, boundary):
    """A uniform 3-D lattice runs on the 7-point stencil (cube_step); an editable session keeps it
    on the CSR spring lists (network_step). 3000 samples of a pluck into an interior cell and
    noise into a face cell: the same positions and velocities to rounding, everywhere in the
    cube. The stencil steps in one pass (velocities from two positions), the lists in two: they
    sum in another order, and over 3000 steps those 1e-16 differences grow to about 1e-12 of the
    peak in the free cube (its rigid mode integrates them), so 1e-10; a wrong neighbour or a lost
    force is off by the signal itself."""
    from hapticgraph.graph.engine import Runner
    text = (f"hapticgraph: 1\nrate: 44100\nblocks:\n"
            f"  L: {{type: lattice, shape: [5, 4, 6], mass: 0.001, tension: 8.0e4, damping: 0.003, "
            f"boundary: {boundary}}}\n"
            f"  hit: {{type: pluck, time: 0.001, force: 1.0, duration: 0.0005}}\n"
            f"  nz: {{type: noise, amplitude: 0.05, seed: 3}}\n"
            f"connect:\n  - hit.out -> L[2, 1, 3].force\n  - nz.out -> L[0, 3, 5].force\n")
    patch = load(write_patch(text))
    cells = {}
    for editable in (False, True):
        s = Runner(patch, editable=editable)
        assert (s.prog.group_of["L"].group.stencil is None) == editable
        s.process(3000)
        pts = s.prog.points("L")
        cells[editable] = [pts.positions.reshape(-1).copy(), pts.velocities.reshape(-1).copy()]
    for stencil, csr in zip(cells[False], cells[True]):
        assert np.max(np.abs(stencil)) > 0
        np.testing.assert_allclose(stencil, csr, rtol=0, atol=1e-10 * np.max(np.abs(csr)))
    assert cells[False][0].shape == (120,)


# -- stability refusal -----------------------------------------------------------------------
def _largest(err, what="tension"):
    m = re.search(rf"largest stable {what} ([0-9.e+]+) N/m", err)
    return float(m.group(1))


@pytest.mark.parametrize("case", ["string", "damped_sheet", "overridden_cell"])
def test_an_unstable_lattice_is_refused_naming_the_cell_and_the_largest_stable_tension(
        write_patch, capsys, case):
    """dt²·Σk/m + dt·γ/m ≥ 2: `check` exits 2 with FILE:LINE of the lattice, the worst cell and the
    largest stable tension; that tension (less 0.1 %) passes, 0.1 % more is refused."""
    fs, m = 44100.0, 1e-3
    if case == "string":          # every cell has Σk = 2T (the ends: one neighbour + the anchor)
        shape, extra, damping, cell, exc = "[20]", "", 0.0, "L[0]", "L[3]"
        t_max = m * fs * fs
    elif case == "damped_sheet":  # every cell has Σk = 4T
        shape, extra, damping, cell, exc = "[6, 7]", "", 0.01, "L[0, 0]", "L[3, 3]"
        t_max = (2 - 0.01 / (m * fs)) * m * fs * fs / 4
    else:                         # one lighter cell in the middle is the worst
        shape, extra, damping, cell, exc = "[20]", ", cells: [{index: [8], mass: 0.0005}]", 0.0, "L[8]", "L[3]"
        t_max = 0.0005 * fs * fs

    def text(T):
        return (f"hapticgraph: 1\nrate: 44100\nblocks:\n  hit: {{type: pluck}}\n"
                f"  L: {{type: lattice, shape: {shape}, mass: {m}, tension: {T!r}, damping: {damping}{extra}}}\n"
                f"connect:\n  - hit.out -> {exc}.force\n")
    bad = write_patch(text(1.5 * t_max), name="bad.yaml")
    assert main(["check", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{bad}:5: block 'L' (lattice): unstable at 44100 Hz: cell {cell} "), err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    hint = _largest(err)
    assert hint == pytest.approx(t_max, rel=1e-3)
    ok = write_patch(text(t_max * 0.999), name="ok.yaml")
    assert main(["check", str(ok)]) == 0
    capsys.readouterr()
    over = write_patch(text(t_max * 1.001), name="over.yaml")
    assert main(["check", str(over)]) == 2
    assert "unstable" in capsys.readouterr().err
    # the stable one really is stable: lossless energy stays bounded
    y = render(load(ok), 0.2, probes=[f"{cell}.position"]).probes[f"{cell}.position"]
    assert np.all(np.isfinite(y)) and np.max(np.abs(y)) < 1.0


@pytest.mark.parametrize("case", ["uniform", "overridden_cell"])
def test_the_smallest_stable_mass_hint_is_the_mass_of_the_cell_at_fault(write_patch, capsys, case):
    """The hint names the mass to give: the lattice's `mass` when the worst cell takes it, that
    cell's own `mass` (cells:) when it has one. Given it (plus 0.1 %) the patch passes; less is
    refused. (Issue 33: a 1e-6 kg cell of a 1 kg lattice was told "smallest stable mass 1.4 kg".)"""
    fs, T = 44100.0, 2.0e3
    lattice_mass = 1.0 if case == "overridden_cell" else 5e-7
    m_needed = 2 * T / (2 * fs * fs)          # the string's cells: Σk = 2T, dt²·Σk/m < 2

    def text(cell_mass):
        if case == "uniform":
            return (f"hapticgraph: 1\nrate: 44100\nblocks:\n  hit: {{type: pluck}}\n"
                    f"  L: {{type: lattice, shape: [20], mass: {cell_mass!r}, tension: {T}}}\n"
                    f"connect:\n  - hit.out -> L[3].force\n")
        return (f"hapticgraph: 1\nrate: 44100\nblocks:\n  hit: {{type: pluck}}\n"
                f"  L: {{type: lattice, shape: [20], mass: {lattice_mass}, tension: {T}, "
                f"cells: [{{index: [8], mass: {cell_mass!r}}}]}}\n"
                f"connect:\n  - hit.out -> L[3].force\n")
    bad = write_patch(text(1e-6 if case == "overridden_cell" else lattice_mass), name="bad.yaml")
    assert main(["check", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    hint = float(re.search(r"smallest stable mass (?:of cell L\[8\] )?([0-9.e+-]+) kg", err).group(1))
    assert hint == pytest.approx(m_needed, rel=1e-3), err
    if case == "overridden_cell":
        assert "smallest stable mass of cell L[8]" in err
    assert main(["check", str(write_patch(text(hint * 1.001), name="ok.yaml"))]) == 0
    assert main(["check", str(write_patch(text(hint * 0.999), name="over.yaml"))]) == 2
    capsys.readouterr()


# -- compiled == interpreter ------------------------------------------------------------------
EQUIVALENCE = {
    "locked": ("L: {type: lattice, shape: [16], mass: 0.001, tension: 2.0e5, lock: [[5], [11]]}",
               ["L[3]", "L[8]"]),
    "cut": ("L: {type: lattice, shape: [6, 5], mass: 0.001, tension: 1.0e5, cut: [[2, 2], [3, 2]]}",
            ["L[3, 1]", "L[4, 4]"]),
    "free_damped": ("L: {type: lattice, shape: [5, 6], mass: 0.001, tension: 1.0e5, damping: 0.01, boundary: free}",
                    ["L[0, 0]", "L[4, 5]"]),
    "overrides": ("L: {type: lattice, shape: [3, 4, 5], mass: 0.001, tension: 8.0e4, "
                  "cells: [{index: [1, 1, 1], mass: 0.003}, {index: [2, 2, 2], damping: 0.05}, "
                  "{index: [0, 0, 0], locked: true}]}", ["L[1, 1, 1]", "L[2, 3, 4]"]),
    "cube": ("L: {type: lattice, shape: [4, 5, 6], mass: 0.001, tension: 8.0e4, damping: 0.002}",
             ["L[1, 2, 3]", "L[2, 2, 5]", "L[0, 4, 1]"]),
    "cube_free": ("L: {type: lattice, shape: [3, 4, 3], mass: 0.001, tension: 8.0e4, boundary: free}",
                  ["L[1, 1, 1]", "L[2, 3, 2]"]),
    "4d": ("L: {type: lattice, shape: [3, 3, 4, 4], mass: 0.001, tension: 5.0e4, damping: 0.002}",
           ["L[1, 1, 1, 1]", "L[2, 2, 3, 0]"]),
    "joined": ("L: {type: lattice, shape: [12], mass: 0.001, tension: 1.0e5}\n"
               "  P: {type: lattice, shape: [4, 4], mass: 0.002, tension: 3.0e4, damping: 0.01}\n"
               "  C: {type: cell, mass: 0.004, damping: 0.02}\n"
               "  j1: {type: spring, a: \"L[10]\", b: \"P[1, 2]\", tension: 5000.0}\n"
               "  j2: {type: spring, a: \"P[3, 3]\", b: C, tension: 2000.0}",
               ["L[3]", "P[2, 2]", "C"]),
    "live_mass_tension": ("L: {type: lattice, shape: [8, 6], mass: 0.001, tension: 1.0e5}\n"
                          "  mk: {type: constant, value: 0.002}\n  tk: {type: constant, value: 7.0e4}",
                          ["L[3, 2]", "L[5, 5]"]),
}


@pytest.mark.parametrize("name", list(EQUIVALENCE))
def test_compiled_equals_interpreter_on_lattices(write_patch, name):
    """Sample for sample (≤ 1e-12) over 2000 samples: positions and velocities of several cells
    (a pluck into the first, noise into the last)."""
    body, cells = EQUIVALENCE[name]
    extra = "  - mk.out -> L.mass\n  - tk.out -> L.tension\n" if name == "live_mass_tension" else ""
    text = (f"hapticgraph: 1\nrate: 44100\nblocks:\n  {body}\n"
            f"  hit: {{type: pluck, time: 0.001, force: 1.0, duration: 0.0005}}\n"
            f"  nz: {{type: noise, amplitude: 0.05, seed: 3}}\n"
            f"connect:\n  - hit.out -> {cells[0]}.force\n  - nz.out -> {cells[-1]}.force\n{extra}")
    path = write_patch(text)
    probes = [f"{c}.{port}" for c in cells for port in ("position", "velocity")]
    a = render(load(path), 2000 / FS, probes=probes)
    b = render(load(path), 2000 / FS, probes=probes, engine="python")
    for k in probes:
        assert np.max(np.abs(a.probes[k])) > 0, k
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12, err_msg=k)
