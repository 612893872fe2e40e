"""patches/poly_strings.yaml: six Karplus-Strong strings played from patches/poly_chords.mid by a
`voices:` template. Each note starts at its exact sample on the voice the allocator gives it
(free first, else the oldest stolen), the strings sound at the notes' pitches, released strings
ring on until reused, and the compiled kernel equals the interpreter bit for bit."""
import math
import pathlib
import sys
from fractions import Fraction

import mido
import numpy as np
import pytest

import hapticgraph

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from poly_song import NOTES, song  # noqa: E402

from analysis import estimate_f0  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
PATCH = ROOT / "patches" / "poly_strings.yaml"
RATE = 44100
SECONDS = 1.6
# (tick, key) -> the voice it must take: the E minor strum on free voices 1 … 6; the A chord on
# the voices released longest ago (released in key order: 1 … 6); 73 steals voice 1 (45, the
# oldest note); 76 takes voice 2 (released first at tick 1152), not voice 6 (69, still held)
VOICE = {(10, 40): 1, (39, 47): 2, (68, 52): 3, (97, 55): 4, (126, 59): 5, (155, 64): 6,
         (576, 45): 1, (599, 52): 2, (622, 57): 3, (645, 61): 4, (668, 64): 5, (691, 69): 6,
         (714, 73): 1, (1248, 76): 2}
STOLEN = {(714, 73)}
PROBES = [f"v{k}_{port}" for k in range(1, 7) for port in ("note.gate", "note.freq", "pick.out", "str.out")]


def sample(tick):
    """⌈t·fs⌉ of a tick at 480 ticks per beat, 120 beats per minute (1/960 s), exactly."""
    return math.ceil(Fraction(tick * RATE, 960))


def freq(key):
    return 440.0 * math.pow(2.0, (key - 69.0) / 12.0)


@pytest.fixture(scope="module")
def render():
    patch = hapticgraph.load(PATCH)
    return hapticgraph.render(patch, SECONDS, probes=PROBES, chunk=1000)


def test_the_midi_file_is_its_generator():
    shipped = mido.MidiFile(ROOT / "patches" / "poly_chords.mid")
    assert [m.bytes() + [m.time] for m in shipped.tracks[0] if not m.is_meta] == \
           [m.bytes() + [m.time] for m in song().tracks[0] if not m.is_meta]
    assert len(VOICE) == sum(kind == "on" for _, kind, _ in NOTES)


def test_each_note_starts_on_its_voice_at_its_sample(render):
    p = render.probes
    for (tick, key), k in VOICE.items():
        s = sample(tick)
        gate, hz, pick = p[f"v{k}_note.gate"], p[f"v{k}_note.freq"], p[f"v{k}_pick.out"]
        assert hz[s] == freq(key) and hz[s - 1] != freq(key), (tick, key)
        if (tick, key) in STOLEN:        # the gate dips at the sample before the note-on, rises at it
            assert (gate[s - 2], gate[s - 1], gate[s]) == (1.0, 0.0, 1.0)
        else:
            assert (gate[s - 1], gate[s]) == (0.0, 1.0), (tick, key)
        start = s + 1                    # pluck starts the sample after its trigger rises, stolen or not
        assert pick[start - 1] == 0.0 and pick[start] > 0.0, (tick, key)
    for k in range(1, 7):               # the first sound of each string: the burst, one loop later
        first = min(sample(t) for (t, _), v in VOICE.items() if v == k)
        key = next(key for (t, key), v in VOICE.items() if v == k and sample(t) == first)
        delay = int(RATE / freq(key) - 1.0)
        sound = render.probes[f"v{k}_str.out"]
        assert np.flatnonzero(sound)[0] == first + 1 + delay


def test_released_strings_ring_until_reused_and_sound_in_tune(render):
    p = render.probes
    off = sample(480)
    for (tick, key), k in list(VOICE.items())[:6]:        # the E minor strum
        reuse = sample(next(t for (t, _), v in list(VOICE.items())[6:] if v == k))
        gate, sound = p[f"v{k}_note.gate"], p[f"v{k}_str.out"]
        assert gate[off:reuse].max() == 0.0
        before, after = np.abs(sound[off - 1000:off]).max(), np.abs(sound[reuse - 1000:reuse]).max()
        assert after > 0.5 * before > 0.0, key       # the release does not damp it: it rings on
        # in tune: the loop is fs/f samples exactly at low frequencies (the lowpass adds 1, the
        # linear interpolation's phase delay is its fraction to O(ω²): < 0.01 cent here), and the
        # autocorrelation estimate resolves far below 0.01 sample; 0.05 % is under a cent
        ringing = sound[sample(tick) + 2048:reuse]
        assert estimate_f0(ringing, RATE) == pytest.approx(freq(key), rel=5e-4), key


def test_the_mix_is_every_voice(render):
    voices = sum(render.probes[f"v{k}_str.out"] for k in range(1, 7))
    np.testing.assert_allclose(render.audio[:, 0], 0.3 * voices, rtol=1e-12, atol=1e-15)
    assert np.abs(render.audio).max() > 0.1


def test_compiled_equals_interpreter_bit_for_bit(render):
    patch = hapticgraph.load(PATCH)
    slow = hapticgraph.render(patch, SECONDS, probes=PROBES, engine="python", chunk=777)
    assert np.array_equal(slow.audio, render.audio)
    for name in PROBES:
        assert np.array_equal(slow.probes[name], render.probes[name]), name
