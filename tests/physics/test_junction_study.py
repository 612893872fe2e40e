"""Explicit vs implicit control junction (seed 000 Sec. 3.1 and 3.3): a string bound at one point by
a spring k to a fixed anchor (the device held still at x = 0, v = 0).

The string: rigid ends reflecting with gain −g_end (no filter, so the only phase is the delays),
the control point D1 samples (one way) from the nut and D2 from the bridge; round trip
N = 2(D1 + D2). Implicit: `implicit_junction` (k, R = 0, pole p) with xm = vm = 0 (unconnected).
Explicit: `explicit_junction` + `displacement_estimator` (pole p) + `spring_damper` (x1 = v1 = 0,
R = 0); its two unit delays are taken out of the bridge side's delay lines, so both model the
same string (fs/N at k = 0) with the sensor D1 samples from the nut.

Continuous-time prediction. Displacement y(x) of a string of tension T, wave speed c,
impedance R0 = T/c, fixed at x = 0 and x = L, with a spring k at x = a:
  y = Y sin(κx)/sin(κa) for x < a, y = Y sin(κ(L − x))/sin(κ(L − a)) for x > a, κ = ω/c;
force balance at a: T(y'(a+) − y'(a−)) = k·Y, with y'(a−) = Yκ cot(κa), y'(a+) = −Yκ cot(κ(L − a)):
  −Tκ(cot(κa) + cot(κ(L − a))) = k   ⇔   R0·ω·(cot(ωa/c) + cot(ω(L − a)/c)) = −k.
In delays, ωa/c = Ω·D1 and ω(L − a)/c = Ω·D2 (Ω = ω/fs rad/sample):
  cot(Ω·D1) + cot(Ω·D2) = −k/(R0·Ω·fs).
The fundamental is its lowest root, in (π/(D1 + D2), π/D2): fs/N at k = 0, rising to fs/(2·D2)
(the longer segment clamped) as k → ∞. (With the sign of the brief, +k, the root would fall,
below fs/N: a spring pulling the point back can only raise the pitch.)

Stability bound of the explicit junction. Near Nyquist (z = −1) the estimator gives
x̂ = v/(fs(1 − p·z⁻¹)) = v/(fs(1 + p)), and the force reaches the string one sample late (z⁻¹ = −1):
the loop F → v → x̂ → F has q = z⁻¹·(k/(2R0))/(fs(1 − p z⁻¹)) = −G/(1 + p), G = k/(2R0·fs).
A wave arriving at the junction leaves it reflected by −ρ, ρ = q/(1 + q) (bL = −ρ·aL + …), so
|ρ| = G/(1 + p − G): above G = (1 + p)/2 ≈ 1 the junction reflects near-Nyquist waves with gain
> 1, and with the string end reflecting by g_end a string segment becomes a resonator of loop
gain |ρ|·g_end > 1 once
  G > (1 + p)/(1 + g_end),   i.e.   k > k_bound = 2R0·fs·(1 + p)/(1 + g_end)  ≈ 2R0·fs.
(The segment's resonance sits just off Nyquist, where |ρ| is a little smaller, so the measured
threshold lies a little above k_bound.) The implicit junction solves F with v in the same
sample: q = (k/(2R0))/(fs(1 − p z⁻¹)) > 0 at Nyquist, 0 < ρ < 1 for every k: no such bound.

The table of this study is in docs/junction_study.md; `python tests/physics/test_junction_study.py`
prints it again (markdown).
"""
import math
import pathlib
import sys
import tempfile

import numpy as np
import pytest

from hapticgraph import load, render

FS = 19000          # the seed's servo/audio rate [Hz]
R0 = 0.5            # string impedance [N·s/m]
D1, D2 = 15, 35     # one-way delays nut–point and point–bridge [samples]: a = 0.3 L, N = 100
G_END = 0.999       # end reflection gain magnitude
POLE = 0.9999       # displacement estimator leak p (both junctions)
SECONDS = 1.0
KS = [0.0, 10.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 15000.0, 18000.0, 20000.0, 30000.0,
      1e5, 1e6]


def patch_text(kind):
    head = f"""hapticgraph: 1
name: spring-bound string ({kind} junction)
rate: {FS}
blocks:
  nut:    {{type: gain, gain: {-G_END}}}
  bridge: {{type: gain, gain: {-G_END}}}
  r1:     {{type: delay, length: {D1}}}
  l2:     {{type: delay, length: {D1}}}
  kick:   {{type: pluck, time: 0.0, force: 1.0, duration: {1.0 / FS!r}}}
"""
    conns = """connect:
  - kick.out -> r1.in
  - nut.out -> r1.in
  - r1.out -> j.aL
  - j.aR -> r2.in
  - r2.out -> bridge.in
  - bridge.out -> l1.in
  - l1.out -> j.bR
  - j.bL -> l2.in
  - l2.out -> nut.in
"""
    if kind == "implicit":
        return head + f"""  r2:     {{type: delay, length: {D2}}}
  l1:     {{type: delay, length: {D2}}}
  j:      {{type: implicit_junction, impedance: {R0}, k: 0.0, R: 0.0, pole: {POLE}}}
""" + conns
    return head + f"""  r2:     {{type: delay, length: {D2 - 1}}}
  l1:     {{type: delay, length: {D2 - 1}}}
  j:      {{type: explicit_junction, impedance: {R0}}}
  xs:     {{type: displacement_estimator, pole: {POLE}}}
  link:   {{type: spring_damper, k: 0.0, R: 0.0}}
""" + conns + """  - j.v -> xs.in
  - xs.out -> link.x2
  - j.v -> link.v2
  - link.force -> j.force
"""


K_PARAM = {"implicit": "j.k", "explicit": "link.k"}


def predicted_f0(k, d1=D1):
    """Lowest root of cot(Ω·d1) + cot(Ω·d2) + k/(R0·Ω·fs) = 0 (d2 = D1 + D2 − d1), in Hz (bisection)."""
    d2 = D1 + D2 - d1

    def f(w):
        return 1.0 / math.tan(w * d1) + 1.0 / math.tan(w * d2) + k / (R0 * w * FS)
    lo, hi = math.pi / (d1 + d2), math.pi / max(d1, d2) * (1 - 1e-12)
    if k == 0.0:
        return FS / (2 * (d1 + d2))
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi) * FS / (2 * math.pi)


def k_bound():
    return 2 * R0 * FS * (1 + POLE) / (1 + G_END)


class Runner:
    """Renders the two patches (written once to a temporary folder) for any k."""

    def __init__(self, folder):
        self.paths = {}
        for kind in ("explicit", "implicit"):
            path = pathlib.Path(folder) / f"{kind}.yaml"
            path.write_text(patch_text(kind), encoding="utf-8")
            self.paths[kind] = path

    def signal(self, kind, k, seconds=SECONDS):
        patch = load(self.paths[kind], overrides=[f"{K_PARAM[kind]}={k!r}"])
        return render(patch, seconds, probes=["r2.out"]).probes["r2.out"]

    def grows(self, kind, k, seconds=SECONDS):
        return unbounded(self.signal(kind, k, seconds))


def unbounded(y):
    """Growing without bound: non-finite, or the last 0.1 s peaks 10 times higher than the whole
    first half. (A stable string rings down; a clamped one may rise slowly to a bounded level —
    the slow mode of the leaky estimator —; an unstable one grows exponentially, by 10 within
    half the render already when its pole lies 1.2e-4 outside the unit circle, for 2 s.)"""
    w = int(0.1 * FS)
    if not np.all(np.isfinite(y)):
        return True
    return bool(np.max(np.abs(y[-w:])) > 10 * np.max(np.abs(y[: len(y) // 2])))


def spectral_peak(y, f_guess):
    """Frequency of the highest spectral peak within ±25 % of f_guess (Hann window, 4 M-point
    FFT, parabolic interpolation of the log magnitude)."""
    nfft = 1 << 22
    spec = np.abs(np.fft.rfft(y * np.hanning(len(y)), nfft))
    freqs = np.fft.rfftfreq(nfft, 1.0 / FS)
    window = (freqs > 0.75 * f_guess) & (freqs < 1.25 * f_guess)
    i = int(np.argmax(np.where(window, spec, 0.0)))
    a, b, c = np.log(spec[i - 1: i + 2])
    return freqs[i] + 0.5 * (a - c) / (a - 2 * b + c) * (freqs[1] - freqs[0])


def measure(runner, k):
    row = {"k": k, "predicted": predicted_f0(k)}
    for kind in ("explicit", "implicit"):
        y = runner.signal(kind, k)
        stable = not unbounded(y)
        row[f"{kind}_stable"] = stable
        row[kind] = spectral_peak(y, row["predicted"]) if stable else math.nan
        row[f"{kind}_error"] = row[kind] / row["predicted"] - 1 if stable else math.nan
    # the explicit junction's control point taken in the middle of its unit delay
    row["explicit_error_mid"] = row["explicit"] / predicted_f0(k, D1 + 0.5) - 1
    return row


def explicit_threshold(runner, lo=10000.0, hi=30000.0, rel=1e-3):
    """Bisection on k between a stable lo and an unstable hi (2 s renders)."""
    assert not runner.grows("explicit", lo, 2.0) and runner.grows("explicit", hi, 2.0)
    while hi - lo > rel * lo:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if runner.grows("explicit", mid, 2.0) else (mid, hi)
    return lo, hi


def table_markdown(rows, threshold):
    def f(x):
        return "—" if math.isnan(x) else f"{x:.3f}"

    def e(x):
        return "unstable" if math.isnan(x) else f"{100 * x:+.4f} %"
    lines = ["| k [N/m] | k/(2R0·fs) | predicted f0 [Hz] | explicit f0 [Hz] | explicit error | "
             "explicit error, point at D1 + ½ | implicit f0 [Hz] | implicit error |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['k']:g} | {r['k'] / (2 * R0 * FS):.4g} | {r['predicted']:.3f} | {f(r['explicit'])} | "
                     f"{e(r['explicit_error'])} | {e(r['explicit_error_mid'])} | {f(r['implicit'])} | "
                     f"{e(r['implicit_error'])} |")
    lo, hi = threshold
    lines += ["", f"Explicit junction: stable at k = {lo:.0f} N/m, unstable at k = {hi:.0f} N/m "
              f"(k/(2R0·fs) = {lo / (2 * R0 * FS):.4f} … {hi / (2 * R0 * FS):.4f}); "
              f"bound k_bound = 2R0·fs·(1 + p)/(1 + g_end) = {k_bound():.0f} N/m."]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def runner(tmp_path_factory):
    return Runner(tmp_path_factory.mktemp("junction_study"))


@pytest.fixture(scope="module")
def table(runner):
    rows = [measure(runner, k) for k in KS]
    threshold = explicit_threshold(runner)
    print("\n" + table_markdown(rows, threshold))
    return {r["k"]: r for r in rows}, threshold


def test_prediction_limits():
    """fs/N at k = 0; rises monotonically; → fs/(2·D2) (the point clamped) as k → ∞."""
    assert predicted_f0(0.0) == FS / 100
    fs_ = [predicted_f0(k) for k in KS]
    assert all(b > a for a, b in zip(fs_, fs_[1:]))
    assert predicted_f0(1e9) == pytest.approx(FS / (2 * D2), rel=1e-5)
    # small k: first-order perturbation of mode 1 (shape φ = sin(πx/L), modal stiffness
    # K1 = T·π²/(2L)): Δω/ω0 = k·φ(a)²/(2·K1) → Δf = k·sin²(πa/L)/(2π²·R0), since R0 = T/c
    small = 1.0
    df = predicted_f0(small) - FS / 100
    assert df == pytest.approx(small * math.sin(math.pi * D1 / (D1 + D2)) ** 2 / (2 * math.pi ** 2 * R0), rel=1e-3)


def test_free_string_both_junctions_at_fs_over_n(table):
    rows, _ = table
    assert abs(rows[0.0]["explicit_error"]) < 1e-5 and abs(rows[0.0]["implicit_error"]) < 1e-5


def test_implicit_matches_the_continuous_prediction_at_every_k(table):
    rows, _ = table
    for k, r in rows.items():
        assert r["implicit_stable"], k
        assert abs(r["implicit_error"]) < 1e-4, (k, r)


def test_implicit_is_more_accurate_than_explicit(table):
    """Wherever the spring matters (k ≥ 100 N/m) and the explicit junction is stable, its
    error is at least 10 times the implicit junction's; it grows with k to over 1 %."""
    rows, _ = table
    stable = [r for k, r in rows.items() if k >= 100 and r["explicit_stable"]]
    assert len(stable) >= 5
    for r in stable:
        assert abs(r["implicit_error"]) * 10 <= abs(r["explicit_error"]), r
    assert rows[10000.0]["explicit_error"] > 0.01


def test_explicit_spring_acts_half_a_sample_further_from_the_nut(table):
    """The explicit junction's sensor reads aL undelayed but bR one sample late, and injects the
    force into both directions one sample late: its control point sits in the middle of its unit
    delay. With a = D1 + ½ the prediction meets it within 0.25 % at every stable k (the rest:
    the one-sample force latency), where with a = D1 it is off by up to 1.4 %."""
    rows, _ = table
    for k, r in rows.items():
        if k >= 100 and r["explicit_stable"]:
            assert abs(r["explicit_error_mid"]) < 0.0025, (k, r)
            assert abs(r["explicit_error_mid"]) < abs(r["explicit_error"]), (k, r)


def test_explicit_goes_unstable_near_the_bound_implicit_never(table, runner):
    rows, (lo, hi) = table
    bound = k_bound()
    assert bound <= lo * 1.001 and hi <= 1.05 * bound            # just above the derived bound
    for k, r in rows.items():
        assert r["explicit_stable"] == (k < lo), (k, r)
        assert r["implicit_stable"], k
    assert runner.grows("explicit", 1e6, 0.2)                    # blows up within 0.2 s
    assert not runner.grows("implicit", 1e9, 2.0)                # the parameter's maximum


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as folder:
        r = Runner(folder)
        rows = [measure(r, k) for k in KS]
        sys.stdout.write(table_markdown(rows, explicit_threshold(r)) + "\n")
