"""`hapticgraph play` through the real audio stack: PortAudio → ALSA `file` PCM (bytes compared with
`run`'s render) and PortAudio → a `jackd -d dummy` server (real-time pacing, xruns, callback load),
plus the safety mute (NaN blow-up: zero force in that block, 5 ms fade)."""
import re

import numpy as np
import pytest
from scipy.io import wavfile

from audio_env import alsa_file_env, align, hapticgraph, jack_or_skip, parse_report, read_raw
from hapticgraph.devices.record import Take

# a sine that is heard, and a feedback loop (gain 2 every 30 samples) into the finger's force
# that overflows to infinity after about 0.7 s: the force column goes non-finite
BLOWUP = """
hapticgraph: 1
rate: 44100
devices:
  finger: {driver: simulated, max_force: 2.0, script: [{t: 0.0, x: 0.0}, {t: 2.0, x: 0.01}]}
blocks:
  tone: {type: wavetable, shape: sine, frequency: 441.0, amplitude: 0.5}
  kick: {type: pluck, duration: 0.0005}
  loop: {type: delay, length: 30}
  amp: {type: gain, gain: 2.0}
  pick: {type: haptic, device: finger}
  out: {type: audio_out, channels: 1}
connect:
  - kick.out -> loop.in
  - amp.out -> loop.in
  - loop.out -> amp.in
  - amp.out -> pick.force
  - tone.out -> out.ch0
"""


@pytest.fixture
def jack(tmp_path):
    server = jack_or_skip(tmp_path)
    yield server
    server.stop()


@pytest.mark.parametrize("patch, blocksize, seconds", [
    ("karplus_strong.yaml", 64, 1.0),
    ("fig7_bowed_string.yaml", 100, 0.6),       # a simulated haptic device, 19 kHz, blocks of 100
])
def test_play_sends_what_run_renders(patches_dir, tmp_path, patch, blocksize, seconds):
    env, raw = alsa_file_env(tmp_path)
    ref = tmp_path / "run.wav"
    r = hapticgraph(["run", patches_dir / patch, "--seconds", seconds, "--out", ref, "--quiet"], env)
    assert r.returncode == 0, r.stderr
    p = hapticgraph(["play", patches_dir / patch, "--seconds", seconds, "--blocksize", blocksize], env)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    rate, rendered = wavfile.read(ref)
    assert rendered.dtype == np.float32
    rendered = rendered.reshape(len(rendered), -1)
    played = read_raw(raw, rendered.shape[1])
    k = align(played, rendered)
    assert k >= 0
    # the same float32 samples, bit for bit, with only PortAudio's priming silence around them
    assert np.array_equal(played[k:k + len(rendered)].view(np.uint32), rendered.view(np.uint32))
    assert not played[:k].any() and not played[k + len(rendered):].any()
    report = parse_report(p.stdout)
    assert report["seconds"] == pytest.approx(seconds, abs=1e-3)
    assert report["xruns"] is not None


def test_jack_dummy_real_time(patches_dir, jack):
    """A second of audio at 64-frame blocks against JACK's clock: xruns counted from the status
    flags, the callback well within its period, and the pacing real."""
    p = hapticgraph(["play", patches_dir / "karplus_strong.yaml", "--seconds", 1.0, "--blocksize", 64,
                     "--audio-device", "system"], jack.env)
    assert p.returncode == 0, p.stderr + jack.text()
    assert "JACK" in p.stdout
    rep = parse_report(p.stdout)
    assert rep["seconds"] == pytest.approx(1.0, abs=1e-3)
    assert rep["xruns"] is not None and rep["xruns"] >= 0      # the status flags were read and counted
    assert rep["callbacks"] >= 44100 // 64
    assert rep["mean"] < 1.0 and rep["p99"] < 1.0
    assert 0.9 < rep["wall"] < 2.0       # paced by the server's clock, not as fast as possible


def test_blowup_zeroes_force_and_fades(tmp_path, write_patch):
    env, raw = alsa_file_env(tmp_path)
    path = write_patch(BLOWUP)
    take = tmp_path / "blow"
    p = hapticgraph(["play", path, "--seconds", 5, "--blocksize", 64, "--record", take], env)
    assert p.returncode == 1
    assert "Traceback" not in p.stderr
    assert re.search(r"stopped after [0-9.]+ s: (numerical blow-up|runaway: pick.force)", p.stderr)
    assert "force sent was zeroed" in p.stderr and "5 ms fade" in p.stderr
    t = Take(f"{take}.hgrec")
    force = t.force_of("finger")
    assert 0 < t.frames < 5 * 44100 and t.frames % 64 == 0
    assert np.all(force[-64:] == 0.0)                          # the faulty block sent no force
    assert np.all(np.isfinite(force[:-64])) and np.any(force[:-64] != 0.0)
    played = read_raw(raw, 1)[:, 0]
    assert np.all(np.isfinite(played))
    _, heard = wavfile.read(f"{take}.wav")
    assert len(heard) == t.frames - 64 + 220                   # good blocks, then the 5 ms fade
    last_good = heard[t.frames - 64 - 1]
    fade = heard[t.frames - 64:]
    assert fade[-1] == 0.0 and abs(last_good) > 1e-3
    expected = (last_good * (1.0 - np.arange(1, 221) / 220.0)).astype(np.float32)
    assert np.allclose(fade, expected, atol=1e-6)
    # the card got the same: the tone, then the ramp to silence (and nothing after)
    end = np.flatnonzero(played)[-1]
    assert np.array_equal(played[end + 2 - len(heard):end + 2], heard) and not played[end + 1:].any()


LIVE = """
hapticgraph: 1
rate: 44100
blocks:
  voice: {type: audio_in, gain: 0.5}
  out: {type: audio_out, channels: 1}
connect:
  - voice.out -> out.ch0
"""


def test_live_audio_input(tmp_path, write_patch):
    """An audio_in block with no file takes the sound card's input (here ALSA's file PCM reading a
    raw file): the same samples reach the kernel, are recorded, and replay offline identically."""
    sent = (0.5 * np.sin(2 * np.pi * 300 * np.arange(44100) / 44100)).astype(np.float32)
    sent.tofile(tmp_path / "in.raw")
    env, raw = alsa_file_env(tmp_path, infile=tmp_path / "in.raw")
    path = write_patch(LIVE)
    take = tmp_path / "voice"
    p = hapticgraph(["play", path, "--seconds", 0.5, "--blocksize", 64, "--record", take], env)
    assert p.returncode == 0, p.stderr
    t = Take(f"{take}.hgrec")
    assert t.frames == 22050 and t.header["drivers"]["voice"]["kind"] == "live audio input"
    assert np.array_equal(t.inputs[:, 0], sent[:22050].astype(np.float64))   # what came in, as it came
    _, heard = wavfile.read(f"{take}.wav")
    assert np.array_equal(heard, (0.5 * sent[:22050].astype(np.float64)).astype(np.float32))
    r = hapticgraph(["run", path, "--replay", f"{take}.hgrec", "--out", tmp_path / "again.wav", "--quiet"], env)
    assert r.returncode == 0, r.stderr
    _, again = wavfile.read(tmp_path / "again.wav")
    assert np.array_equal(again.view(np.uint32), heard.view(np.uint32))
    # without a sound card input, `run` refuses the live block with a clear message
    r = hapticgraph(["run", path, "--out", tmp_path / "x.wav", "--quiet"], env)
    assert r.returncode == 2 and "live input needs `play`" in r.stderr


SHEET = """
hapticgraph: 1
rate: 44100
blocks:
  plate: {type: lattice, shape: [6, 5], mass: 0.001, tension: 100000.0, damping: 0.01}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  loop: {type: delay, length: 37}
  mic: {type: mic, gain: GAIN}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> plate[2, 2].force
  - plate[4, 3].velocity -> loop.in
  - loop.out -> mic.in
  - mic.left -> out.ch0
"""


def test_reload_keeps_state_of_unchanged_blocks(write_patch):
    """carry_state (what --watch does at the swap): cells, delay lines and states of unchanged
    blocks continue exactly; the changed block starts afresh."""
    from hapticgraph import Session
    from hapticgraph.devices.audio import carry_state

    def play_session(path):           # as `play` opens it
        return Session.open(path, blocksize=64, editable=False)
    a = write_patch(SHEET.replace("GAIN", "1.0"), name="a.yaml")
    b = write_patch(SHEET.replace("GAIN", "0.5"), name="b.yaml")
    full = play_session(a)
    ref = np.concatenate([full.process(64)[:, 0].copy() for _ in range(40)])
    old = play_session(a)
    first = np.concatenate([old.process(64)[:, 0].copy() for _ in range(20)])
    pairs, kept = carry_state(old.program, play_session(b).program)
    assert sorted(kept) == ["hit", "loop", "out", "plate"]
    swap = old.swap(b)                # what --watch does: carry_state, applied at the block boundary
    assert swap.kept == sorted(kept) and len(swap.carry) == len(pairs)
    second = np.concatenate([old.process(64)[:, 0].copy() for _ in range(20)])
    assert np.array_equal(first, ref[:1280])
    assert np.array_equal(second, ref[1280:] * 0.5) and np.any(second != 0)
    # a changed lattice starts from rest; an unchanged delay line still holds its samples
    c = write_patch(SHEET.replace("GAIN", "1.0").replace("damping: 0.01", "damping: 0.02"), name="c.yaml")
    _, kept = carry_state(old.program, play_session(c).program)
    assert "plate" not in kept and "loop" in kept
