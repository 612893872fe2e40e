"""The `play` and `devices` commands: bad input is a clear error with exit status 2 and nothing
played; `devices` lists the sound cards; `--watch` swaps a changed patch in at a block boundary,
keeping the state of every block that did not change."""
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy.io import wavfile

from audio_env import alsa_file_env, hapticgraph, jack_or_skip
from hapticgraph.cli import main


@pytest.mark.parametrize("args, message", [
    (["--blocksize", "0"], "--blocksize 0: expected a number of frames"),
    (["--blocksize", "-64"], "--blocksize -64"),
    (["--seconds", "0"], "--seconds must be positive"),
    (["--latency", "soon"], "--latency 'soon': expected low, high or a number of seconds"),
    (["--device", "nobody=simulated"], "the patch declares no device named nobody"),
    (["--device", "finger"], "expected NAME=DRIVER"),
    (["--replay", "x.hgrec", "--device", "a=b"], "--replay feeds every device from the take"),
])
def test_bad_arguments(patches_dir, capsys, args, message):
    assert main(["play", str(patches_dir / "karplus_strong.yaml"), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_patch_error_is_reported_like_run(write_patch, capsys):
    path = write_patch("hapticgraph: 1\nblocks:\n  a: {type: dealy, length: 3}\n")
    assert main(["play", str(path), "--seconds", "1"]) == 2
    err = capsys.readouterr().err
    assert "p.yaml:3:" in err and "dealy" in err and "Traceback" not in err


def test_unknown_audio_device_and_missing_take(tmp_path, patches_dir):
    env, raw = alsa_file_env(tmp_path)
    karplus = patches_dir / "karplus_strong.yaml"
    for device, message in (("nosuch", "no audio output device named 'nosuch'"),
                            ("99", "no audio output device with index 99")):
        p = hapticgraph(["play", karplus, "--audio-device", device, "--seconds", 0.1], env)
        assert p.returncode == 2, p.stderr
        assert message in p.stderr and "default (ALSA)" in p.stderr and "Traceback" not in p.stderr
    p = hapticgraph(["play", karplus, "--replay", tmp_path / "none.hgrec"], env)
    assert p.returncode == 2 and "cannot read take" in p.stderr
    p = hapticgraph(["play", karplus, "--seconds", 0.1, "--record", tmp_path / "no" / "such" / "dir" / "t"], env)
    assert p.returncode == 2 and "--record" in p.stderr and "Traceback" not in p.stderr
    raw = tmp_path / "out.raw"              # PortAudio's probe may create it, but nothing was sent
    assert not raw.exists() or raw.stat().st_size == 0


def test_devices_lists_sound_cards(tmp_path):
    env, raw = alsa_file_env(tmp_path)
    p = hapticgraph(["devices"], env)
    assert p.returncode == 0, p.stderr
    assert "Sound cards (PortAudio):" in p.stdout and "HID devices" in p.stdout
    drivers = p.stdout.split("Drivers (entry points hapticgraph.drivers):\n")[1].split("Sound cards")[0]
    assert [line.split()[0] for line in drivers.splitlines()] == ["evdev", "hid", "midi", "osc", "replay",
                                                                  "serial", "simulated"]
    assert "hapticgraph (hapticgraph.devices.simulated_kind:SimulatedKind)" in drivers
    assert "default  [ALSA]" in p.stdout and "(default output" in p.stdout


WATCHED = """
hapticgraph: 1
name: watched string
rate: 44100
blocks:
  pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
  loop: {type: delay, length: 99}
  damp: {type: lowpass, coeffs: [0.25, 0.5, 0.25], gain: 0.9995}
  mic:  {type: mic, gain: GAIN, pan: 0.0}
  out:  {type: audio_out, channels: 2}
connect:
  - pick.out -> loop.in
  - damp.out -> loop.in
  - loop.out -> damp.in
  - damp.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""


def test_watch_swaps_at_a_block_boundary_keeping_state(tmp_path, write_patch):
    """Playing (paced by a JACK dummy server), the file is saved twice: first with an error (it is
    reported and the old patch keeps playing), then with the mic's gain halved. The string keeps
    ringing through the swap: after it, every sample is exactly half of the uninterrupted render."""
    path = write_patch(WATCHED.replace("GAIN", "0.5"))
    env, _ = alsa_file_env(tmp_path)
    ref = tmp_path / "ref.wav"
    assert hapticgraph(["run", path, "--seconds", 3, "--out", ref, "--quiet"], env).returncode == 0
    jack = jack_or_skip(tmp_path)
    try:
        take = tmp_path / "w"
        proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "play", str(path), "--watch", "--seconds", "3",
                                 "--blocksize", "64", "--audio-device", "system", "--record", str(take)],
                                env=jack.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wav = tmp_path / "w.wav"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if wav.exists() and wav.stat().st_size > 0.5 * 44100 * 8:
                break
            time.sleep(0.05)
        path.write_text(WATCHED.replace("GAIN", "0.5").replace("type: delay", "type: dleay"))
        time.sleep(0.6)
        path.write_text(WATCHED.replace("GAIN", "0.25"))
        out, err = proc.communicate(timeout=60)
    finally:
        jack.stop()
    assert proc.returncode == 0, err
    assert "has errors; still playing the previous version" in err and "dleay" in err
    assert "reloaded p.yaml" in err and "kept the state of 4 block(s): damp, loop, out, pick" in err
    assert "1 swapped in, 1 refused" in out
    _, heard = wavfile.read(wav)
    _, full = wavfile.read(ref)
    assert len(heard) == len(full) == 3 * 44100
    differ = np.flatnonzero(np.any(heard != full, axis=1))
    assert differ.size, "the reload never reached the sound"
    k = int(differ[0])
    assert k % 64 == 0 and 0.5 * 44100 < k < 2.9 * 44100       # at a block boundary, while playing
    assert np.array_equal(heard[k:], full[k:] / np.float32(2.0))  # state kept: the same string, half as loud
    assert np.abs(full[k:]).max() > 1e-3                         # ... still ringing
