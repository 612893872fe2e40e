"""Issue 10 items 5 and 7: memory is bounded and work streams. `run` writes the audio and the
probes to disk block by block, so a render far longer than the child's memory limit finishes; an
audio_in file is resampled as it plays (a WAV at 1 Hz is not first interpolated to the patch rate
for its whole length); a 0-channel or unreadable WAV is a clean error."""
import os
import zipfile

import numpy as np
import soundfile

from hostile_env import assert_patch_error




KARPLUS = os.path.join(os.path.dirname(__file__), "..", "..", "patches", "karplus_strong.yaml")


def _npy_shape(npz, name):
    with zipfile.ZipFile(npz) as zf, zf.open(f"{name}.npy") as entry:
        assert np.lib.format.read_magic(entry) == (1, 0)
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(entry)
        first = np.frombuffer(entry.read(8 * 4410), dtype=dtype)
    return shape, dtype, first


def test_a_render_longer_than_memory_streams(hg, tmp_path):
    """2000 s at 44.1 kHz is 88.2 M samples: the audio and one probe held as float64 arrays need
    over 2 GB, past the child's 1.5 GB limit; streamed, memory stays one block."""
    proc = hg("run", KARPLUS, "--seconds", 2000, "--out", "long.flac", "--probe", "loop.out", "--quiet",
              cwd=tmp_path, timeout=900)
    assert proc.returncode == 0, proc.stderr
    frames = 2000 * 44100
    info = soundfile.info(tmp_path / "long.flac")
    assert info.frames == frames and info.channels == 2
    shape, dtype, first = _npy_shape(tmp_path / "long.npz", "loop.out")
    assert shape == (frames,) and dtype == np.float64
    assert np.abs(first).max() > 0.01                       # the pluck, at the start of the probe
    assert os.path.getsize(tmp_path / "long.npz") > 8 * frames
    assert sorted(os.listdir(tmp_path)) == ["long.flac", "long.npz"]


PATCH_WITH_FILE = """hapticgraph: 1
rate: 44100
blocks:
  src: {type: audio_in, file: slow.wav}
  out: {type: audio_out, channels: 1}
connect:
  - src.out -> out.ch0
"""


def test_a_1hz_wav_is_resampled_as_it_streams(hg, tmp_path):
    """100,000 frames at 1 Hz last 27.8 hours: interpolated up front to 44.1 kHz they are 35 GB."""
    soundfile.write(tmp_path / "slow.wav", np.linspace(0.0, 1.0, 100_000), 1, subtype="FLOAT")
    (tmp_path / "p.yaml").write_text(PATCH_WITH_FILE)
    proc = hg("run", "p.yaml", "--seconds", 2, "--out", "o.wav", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    y, rate = soundfile.read(tmp_path / "o.wav")
    step = 1.0 / 99_999                                         # the ramp's rise per second
    t = np.arange(len(y)) / 44100
    assert rate == 44100 and len(y) == 88200
    np.testing.assert_allclose(y, t * step, rtol=1e-6, atol=1e-9)


def test_a_zero_channel_or_unreadable_wav_is_a_clean_error(hg, tmp_path):
    (tmp_path / "p.yaml").write_text(PATCH_WITH_FILE)
    (tmp_path / "slow.wav").write_bytes(
        b"RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x00\x00\x44\xac\x00\x00"
        b"\x00\x00\x00\x00\x00\x00\x10\x00data\x00\x00\x00\x00")            # fmt: 0 channels
    proc = hg("run", "p.yaml", "--seconds", 0.1, "--out", "o.wav", cwd=tmp_path)
    assert_patch_error(proc, "block 'src' (audio_in): cannot read 'slow.wav'")
    (tmp_path / "slow.wav").write_bytes(b"RIFF\xff\xff\xff\xffWAVEjunk" + bytes(range(256)) * 8)
    proc = hg("run", "p.yaml", "--seconds", 0.1, "--out", "o.wav", cwd=tmp_path)
    assert_patch_error(proc, "slow.wav is not a readable audio file")
    assert sorted(os.listdir(tmp_path)) == ["p.yaml", "slow.wav"]
