"""Record (`play --record TAKE`) and replay (`run --replay TAKE.hgrec`, `driver: replay`): the
replay is what was heard, bit for bit; a take from another patch is refused; Ctrl-C and every
other stop leave complete files."""
import os
import signal
import subprocess
import sys
import time
import types

import numpy as np
import pytest
from scipy.io import wavfile

from audio_env import alsa_file_env, align, hapticgraph, jack_or_skip, read_raw
from hapticgraph import load
from hapticgraph.devices.record import FloatWav, Take, TakeError, replay_drivers, take_paths
from hapticgraph.devices.replay import ReplayDriver
from hapticgraph.graph.engine import render

# a finger plucks a string through a plucker; the take holds the hand's trajectory
PLUCKED = """
hapticgraph: 1
name: plucked by a simulated finger
rate: 44100
devices:
  finger: {driver: simulated, max_force: 4.0, mass: 0.05, hand_stiffness: 400.0, hand_damping: 4.0,
           script: [{t: 0.0, x: -0.002}, {t: 0.02, x: -0.002}, {t: 0.12, x: 0.012}]}
blocks:
  str: {type: lattice, shape: [40], mass: 0.001, tension: 200000.0, damping: 0.01}
  pick: {type: haptic, device: finger}
  pl: {type: plucker, k: 2000.0, release: 2.0}
  mic: {type: mic, gain: 2.0, pan: 0.3}
  out: {type: audio_out}
connect:
  - pick.x -> pl.x1
  - pick.v -> pl.v1
  - str[9].position -> pl.x2
  - str[9].velocity -> pl.v2
  - pl.reaction -> pick.force
  - pl.force -> str[9].force
  - str[30].velocity -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""


def _take(tmp_path, write_patch, seconds=0.5, blocksize=64, text=PLUCKED):
    env, raw = alsa_file_env(tmp_path)
    path = write_patch(text)
    take = tmp_path / "take"
    p = hapticgraph(["play", path, "--seconds", seconds, "--blocksize", blocksize, "--record", take], env)
    assert p.returncode == 0, p.stderr
    assert "recorded" in p.stdout
    return env, raw, path, take


def test_record_then_replay_is_what_was_heard(tmp_path, write_patch):
    env, raw, path, take = _take(tmp_path, write_patch)
    t = Take(f"{take}.hgrec")
    assert t.frames == 22050 and t.rate == 44100
    assert [c for c in t.header["columns"]] == [["finger", "hand_x"], ["finger", "hand_v"], ["finger", "force"]]
    info = t.header["drivers"]["finger"]
    assert info["kind"] == "simulated" and info["model"] == "simulated" and "block_type" not in info
    assert info["block_values"]["max_force"] == 4.0
    assert np.any(t.force_of("finger") != 0.0)                    # the string pushed back on the finger
    rate, heard = wavfile.read(f"{take}.wav")
    assert rate == 44100 and heard.dtype == np.float32 and heard.shape == (22050, 2)
    # what the sound card got is the recorded audio
    played = read_raw(raw, 2)
    k = align(played, heard)
    assert np.array_equal(played[k:k + len(heard)], heard)
    # replayed offline: the same float32 bits
    out = tmp_path / "replayed.wav"
    r = hapticgraph(["run", path, "--replay", f"{take}.hgrec", "--out", out, "--quiet"], env)
    assert r.returncode == 0, r.stderr
    _, again = wavfile.read(out)
    assert again.shape == heard.shape                           # --seconds defaults to the take's length
    assert np.array_equal(again.view(np.uint32), heard.view(np.uint32))
    # a device entry `driver: replay` (the file relative to the patch) feeds that device from the take
    entry = PLUCKED.split("devices:")[0] + "devices:\n  finger: {driver: replay, file: take.hgrec}\nblocks:" + \
        PLUCKED.split("blocks:")[1]
    other = write_patch(entry, name="replayed.yaml")
    r = hapticgraph(["run", other, "--seconds", 0.5, "--out", tmp_path / "entry.wav", "--quiet"], env)
    assert r.returncode == 0, r.stderr
    _, entry_audio = wavfile.read(tmp_path / "entry.wav")
    assert np.array_equal(entry_audio, heard)


def test_replay_through_a_changed_instrument(tmp_path, write_patch):
    """The same gestures replayed through a patch whose parameters changed (same devices)."""
    env, raw, path, take = _take(tmp_path, write_patch, seconds=0.3)
    patch = load(path, overrides=["mic.gain=1.0"])
    _, drivers = replay_drivers(patch, f"{take}.hgrec")
    half = render(patch, 0.3, drivers=drivers, safety=True).audio.astype(np.float32)
    _, heard = wavfile.read(f"{take}.wav")
    assert np.array_equal(half * 2, heard)


def test_take_from_another_patch_is_refused(tmp_path, write_patch, patches_dir):
    env, raw, path, take = _take(tmp_path, write_patch, seconds=0.2)
    os.remove(raw)
    for other in (patches_dir / "fig7_bowed_string.yaml",        # another device (arm), another rate
                  write_patch(PLUCKED.replace("rate: 44100", "rate: 48000"), name="other_rate.yaml")):
        out = tmp_path / "nothing.wav"
        r = hapticgraph(["run", other, "--replay", f"{take}.hgrec", "--out", out, "--quiet"], env)
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert "was recorded from another patch" in r.stderr and "plucked by a simulated finger" in r.stderr
        assert not out.exists()
        p = hapticgraph(["play", other, "--replay", f"{take}.hgrec", "--seconds", 0.1], env)
        assert p.returncode == 2 and "was recorded from another patch" in p.stderr
        assert not os.path.exists(raw)                           # the sound card was never opened
    # not a take at all
    bogus = tmp_path / "bogus.hgrec"
    bogus.write_bytes(b"RIFF....WAVE")
    r = hapticgraph(["run", path, "--replay", bogus, "--out", tmp_path / "n.wav", "--quiet"], env)
    assert r.returncode == 2 and "not a hapticgraph take" in r.stderr
    with pytest.raises(TakeError, match="no device or input named 'hand'"):
        Take(f"{take}.hgrec").driver_info("hand")


def test_ctrl_c_leaves_complete_files(tmp_path, write_patch, patches_dir):
    """SIGINT to a `play` with no --seconds (paced by a JACK dummy server): it fades out, stops,
    and both files are complete; the take replays to what was heard up to the fade."""
    jack = jack_or_skip(tmp_path)
    try:
        path = write_patch(PLUCKED)
        take = tmp_path / "live"
        proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "play", str(path), "--blocksize", "64",
                                 "--audio-device", "system", "--record", str(take)], env=jack.env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        hg = f"{take}.hgrec"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if os.path.exists(hg) and os.path.getsize(hg) > 0.5 * 44100 * 24:
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        jack.stop()
    assert proc.returncode == 130, err                      # interrupted: 128 + SIGINT, the take kept whole
    assert "Traceback" not in err and "interrupted after" in err and "faded out" in err
    t = Take(hg)
    rate, heard = wavfile.read(f"{take}.wav")               # a valid WAV (header matches the data)
    assert os.path.getsize(f"{take}.wav") == 58 + heard.nbytes
    assert len(heard) == t.frames > 0.5 * 44100
    assert np.all(heard[-1] == 0.0) and np.any(heard[-400:-256] != 0.0)
    r = hapticgraph(["run", path, "--replay", hg, "--out", tmp_path / "again.wav", "--quiet"], jack.env)
    assert r.returncode == 0, r.stderr
    _, again = wavfile.read(tmp_path / "again.wav")
    assert len(again) == len(heard)
    # identical up to the 5 ms fade-out, which starts at a block boundary (the last 4 blocks of 64)
    f0 = len(heard) - 256
    assert np.array_equal(again[:f0], heard[:f0])
    ramp = (1.0 - np.arange(1, 221) / 220.0)[:, None]
    assert np.allclose(heard[f0:f0 + 220], again[f0:f0 + 220] * ramp, atol=1e-7)
    assert not heard[f0 + 220:].any()


def test_float_wav_is_valid_at_every_flush(tmp_path):
    path = tmp_path / "w.wav"
    w = FloatWav(str(path), 44100, 2)
    a = np.random.default_rng(1).uniform(-1, 1, (1000, 2)).astype(np.float32)
    w.write(a)
    w.flush()
    rate, got = wavfile.read(path)                 # read while still open: complete and valid
    assert rate == 44100 and np.array_equal(got, a)
    w.write(a[:10])
    w.close()
    _, got = wavfile.read(path)
    assert np.array_equal(got, np.concatenate([a, a[:10]]))


def test_take_with_a_torn_last_row_is_refused_with_the_fix(tmp_path, write_patch):
    """A writer killed mid-row leaves stray bytes: refused (exit 2), naming the whole rows kept and
    the `truncate` that keeps them."""
    env, raw, path, take = _take(tmp_path, write_patch, seconds=0.1)
    hg = f"{take}.hgrec"
    whole = os.path.getsize(hg)
    with open(hg, "ab") as f:
        f.write(b"\x00" * 13)
    with pytest.raises(TakeError, match=rf"4410 rows of 24 bytes and 13 bytes more .*truncate -s {whole} "):
        Take(hg)
    os.truncate(hg, whole)
    assert Take(hg).frames == 4410
    assert take_paths("a/b.hgrec") == ("a/b.hgrec", "a/b.wav") and take_paths("a/b") == ("a/b.hgrec", "a/b.wav")


def test_a_replay_keeps_what_a_device_would_have_received():
    """ReplayDriver.send: a value not finite is kept as 0, each one clamped to the device's
    max_force, the caller's block left as it was."""
    take = types.SimpleNamespace(inputs=np.zeros((4, 1)), rate=1000.0, model_of=lambda name, info: None)
    driver = ReplayDriver("arm", take, {"columns": ["x"], "offset": 0, "max_force": 2.0})
    block = np.array([np.nan, np.inf, -np.inf, 3.0, -5.0, 1.5, -0.0])
    driver.send(0, block)
    driver.send(7, np.array([0.25]))
    np.testing.assert_array_equal(driver.force_sent(), [0.0, 0.0, 0.0, 2.0, -2.0, 1.5, 0.0, 0.25])
    assert np.isnan(block[0]) and block[3] == 3.0
