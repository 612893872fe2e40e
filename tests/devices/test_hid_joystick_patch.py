"""examples/controllers/joystick_lattice.yaml played headless by `hapticgraph run`: a real
joystick's recording (a PS3 controller, top-level collection Joystick) moves a bowed lattice
string's cell mass through `map:` (`axis: pad.z`), and a second real joystick's button (a Namtai
Wbuzz's button17) is the `hold:` button. The recordings are decoded here on their own — their
`E:` lines read as text, the bytes picked at the offsets their descriptors give — and the
sound's pitch is measured around the times they give: steady where the stick rests, steady
while the button holds though the stick moves, a jump at the release of the size the map
predicts; without `hold:` the jump comes where the stick moves."""
import pathlib
import subprocess
import sys

import numpy as np
import pytest
import soundfile

from analysis import estimate_f0

ROOT = pathlib.Path(__file__).resolve().parents[2]
PATCH = ROOT / "examples" / "controllers" / "joystick_lattice.yaml"
DATA = ROOT / "tests" / "data" / "hid"
SECONDS = 1.5
WINDOW = 0.04                     # seconds per pitch estimate: 8 periods at 210 Hz
STEADY = 0.006                    # the bowed string's own wander between windows (measured: ±0.3 %)
M_LO, M_HI = 2.5e-4, 2.5e-2       # the patch's map: min, max (exponential)


def events(path):
    """[(t - t0, report bytes)] of a hid-recorder file's E: lines, read independently of the package."""
    out = []
    for line in path.read_text().splitlines():
        if line.startswith("E: "):
            t, count, *data = line[3:].split()
            assert int(count) == len(data)
            out.append((float(t), bytes(int(b, 16) for b in data)))
    return [(t - out[0][0], data) for t, data in out]


def changes(evs, pick):
    """[(t, value)] where pick(report) takes a new value, the first report included."""
    out = []
    for t, data in evs:
        v = pick(data)
        if not out or v != out[-1][1]:
            out.append((t, v))
    return out


# sony_ps3_controller_054c_0268: report 1 = id, a constant byte, 19 buttons + 13 constant bits,
# then X, Y, Z, Rz of 8 bits, logical 0 … 255: Z is byte 8. namtai_wbuzz_054c_1000: no report id;
# X, Y of 8 bits, then buttons 1 … 20 one bit each: button17 is bit 0 of byte 4.
Z = changes(events(DATA / "sony_ps3_controller_054c_0268_stick.hid"), lambda r: r[8])
BUTTON17 = changes(events(DATA / "namtai_wbuzz_054c_1000.hid"), lambda r: r[4] & 1)


def mass(byte):
    v = 2.0 * byte / 255 - 1.0                       # a centred 8-bit axis on −1 … 1
    return M_LO * (M_HI / M_LO) ** ((v + 1.0) / 2.0)


def render(patch, tmp_path, name):
    out = tmp_path / f"{name}.wav"
    subprocess.run([sys.executable, "-m", "hapticgraph", "run", str(patch), "--seconds", str(SECONDS),
                    "--out", str(out), "-q"], check=True, cwd=tmp_path, timeout=300)
    audio, fs = soundfile.read(out)
    return audio[:, 0], fs


def pitches(audio, fs, start, end):
    """Pitch of every 40 ms window that lies within [start, end) s (10 ms apart)."""
    n = int(WINDOW * fs)
    starts = np.arange(int(start * fs), int(end * fs) - n + 1, int(0.01 * fs))
    assert len(starts) >= 3, (start, end)
    return np.array([estimate_f0(audio[i:i + n], fs, fmin=150.0, fmax=400.0) for i in starts])


def assert_steady(f, at, what):
    assert np.all(np.abs(f / at - 1.0) < STEADY), f"{what}: {np.round(f, 2)} against {at:.2f} Hz"


def test_the_recordings_are_what_the_patch_says():
    rest, moved = Z[0][1], Z[-1][1]
    assert (rest, moved) == (0x81, 0x7C) and len(Z) == 4          # 0x81 -> 0x80 -> 0x7d -> 0x7c
    (t0, up), (press, down), (release, up2) = BUTTON17[:3]
    assert (up, down, up2) == (0, 1, 0)
    assert press < Z[1][0] < Z[-1][0] < release                   # the stick moves while the button is held
    assert Z[1][0] == pytest.approx(0.980009) and release == pytest.approx(1.127987)


@pytest.fixture(scope="module")
def played(tmp_path_factory):
    return render(PATCH, tmp_path_factory.mktemp("held"), "held")


def test_hold_suppresses_the_stick_then_jumps_at_its_release(played):
    audio, fs = played
    press, release = BUTTON17[1][0], BUTTON17[2][0]
    move, settled = Z[1][0], Z[-1][0]
    before = pitches(audio, fs, 0.3, press)
    f0 = np.median(before)
    assert 200.0 < f0 < 220.0
    assert_steady(before, f0, "the stick at rest")
    assert_steady(pitches(audio, fs, press, release), f0, "button17 held, the stick moving under it")
    after = pitches(audio, fs, release + 0.02, SECONDS)
    f1 = np.median(after)
    assert_steady(after, f1, "released")
    # f_1 ∝ √(T/m): the jump is the square root of the mass ratio the two stick positions give
    expected = np.sqrt(mass(Z[0][1]) / mass(Z[-1][1]))
    assert expected == pytest.approx(1.046, abs=0.001)
    assert f1 / f0 == pytest.approx(expected, rel=0.005)
    assert settled < release


def test_without_hold_the_pitch_moves_where_the_stick_does(tmp_path, played):
    text = PATCH.read_text()
    assert ", hold: buzz.button17}" in text and text.count("recording: ../../tests/data/hid/") == 2
    text = text.replace("recording: ../../tests/data/hid/", f"recording: {DATA.as_posix()}/")
    free = tmp_path / "free.yaml"
    free.write_text(text.replace(", hold: buzz.button17}", "}"))
    audio, fs = render(free, tmp_path, "free")
    move, settled = Z[1][0], Z[-1][0]
    before = pitches(audio, fs, 0.3, move)
    after = pitches(audio, fs, settled + 0.03, SECONDS)
    f0, f1 = np.median(before), np.median(after)
    assert_steady(before, f0, "the stick at rest")
    assert_steady(after, f1, "the stick moved")
    assert f1 / f0 == pytest.approx(np.sqrt(mass(0x81) / mass(0x7C)), rel=0.005)
    held_audio, _ = played                     # the two runs agree until the stick moves, bit for bit
    n = int(move * fs)
    np.testing.assert_array_equal(audio[:n], held_audio[:n])
