"""Issue 21 item 1: outputs are sized before rendering. From --seconds, the rate, the channels,
the format and the subtype, `run` knows how large the audio file and the probes' .npz will be
before the first sample: what the format cannot hold or the disk cannot take is refused at once
(exit 2, naming the option, nothing written); a WAV past 4 GB is written as RF64 through
soundfile, and the run says so. `run P --seconds 1e9 --out x.wav` used to start rendering ~150 TB
into a WAV whose header cannot describe more than 4 GB."""
import os

import numpy as np
import pytest
import soundfile

from hostile_env import assert_patch_error

from hapticgraph.cli.common import UsageError
from hapticgraph.cli.sizes import WAV_LIMIT, size_outputs
from hapticgraph.devices.wav import AudioWriter

TONE = """hapticgraph: 1
rate: 8000
blocks:
  tone: {type: wavetable, shape: sine, frequency: 100.0, amplitude: 0.5}
  out: {type: audio_out, channels: 2}
connect:
  - tone.out -> out.left
  - tone.out -> out.right
"""


def test_a_render_no_disk_can_take_is_refused_at_once(hg, write_patch, tmp_path):
    path = write_patch(TONE)
    proc = hg("run", path, "--seconds", "1e9", "--out", "x.wav", "--probe", "tone.out", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "--out 'x.wav'")
    assert "64 TB" in proc.stderr and "free" in proc.stderr, proc.stderr     # 8e12 frames × 2 × 4 bytes
    assert "compile" not in proc.stdout
    assert sorted(os.listdir(tmp_path)) == ["p.yaml"]
    proc = hg("run", path, "--seconds", "1e9", "--out", "x.flac", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "--out 'x.flac'")
    assert "FLAC holds at most" in proc.stderr, proc.stderr
    proc = hg("run", path, "--seconds", "1e6", "--out", "x.aiff", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "AIFF holds at most 4.29 GB")


def test_a_take_is_sized_before_play_opens_anything(hg, write_patch, tmp_path):
    """`play --seconds S --record T`: the take's WAV is known too; refused before any sound card."""
    path = write_patch(TONE)
    proc = hg("play", path, "--seconds", "1e5", "--record", "t", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "--record")
    assert "a take's WAV holds at most 4.29 GB" in proc.stderr, proc.stderr
    proc = hg("play", path, "--seconds", "1e9", "--record", "t", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "--record")
    assert sorted(os.listdir(tmp_path)) == ["p.yaml"]


def test_the_probes_are_sized_too(hg, write_patch, tmp_path):
    path = write_patch(TONE.replace("  out: {type: audio_out, channels: 2}\n", "").split("connect:")[0] + "connect: []\n")
    proc = hg("run", path, "--seconds", "1e9", "--probe", "tone.out", "--probes", "p.npz", cwd=tmp_path, timeout=60)
    assert_patch_error(proc, "--probes 'p.npz'")
    assert "free" in proc.stderr


def test_wav_past_4gb_becomes_rf64(tmp_path):
    frames_over = WAV_LIMIT // 8 + 1                         # stereo FLOAT: 8 bytes a frame
    plan = size_outputs(str(tmp_path / "x.wav"), None, frames_over, 44100.0, 2, 0, None, free=lambda p: 1 << 50)
    assert plan.container == "RF64" and "RF64" in plan.notes[0] and "4.29 GB" in plan.notes[0]
    plan = size_outputs(str(tmp_path / "x.wav"), None, 44100, 44100.0, 2, 0, None, free=lambda p: 1 << 50)
    assert plan.container is None and not plan.notes
    with pytest.raises(UsageError, match="--out .*free"):
        size_outputs(str(tmp_path / "x.wav"), None, 1 << 20, 44100.0, 2, 0, "PCM_16", free=lambda p: 1 << 20)
    w = AudioWriter(tmp_path / "y.wav", 8000, 2, container="RF64")
    w.write(np.full((100, 2), 0.25))
    assert w.close() == 100
    info = soundfile.info(tmp_path / "y.wav")
    assert info.format == "RF64" and info.frames == 100
