"""Issue 10 item 6 and issue 11 item 5: outputs are checked before any work. An extension soundfile
cannot write, a missing folder, a path that is a folder, a device or a pipe, an output naming the
patch or one of its inputs, a --probes not ending in .npz, a --seconds that is not a positive
finite number: exit 2, one clear line, nothing written. Audio goes through soundfile, its format
chosen by the extension; a path is used exactly as given."""
import os

import numpy as np
import pytest
import soundfile

from hostile_env import assert_patch_error




TONE = """hapticgraph: 1
rate: 8000
blocks:
  tone: {type: wavetable, shape: sine, frequency: 100.0, amplitude: 0.5}
  src: {type: audio_in, file: voice.wav}
  out: {type: audio_out, channels: 2}
connect:
  - tone.out -> out.left
  - src.out -> out.right
"""


@pytest.fixture
def tone(tmp_path):
    soundfile.write(tmp_path / "voice.wav", np.zeros(100), 8000)
    path = tmp_path / "tone.yaml"
    path.write_text(TONE)
    return path


def _nothing_new(folder, before):
    assert sorted(os.listdir(folder)) == before


@pytest.mark.parametrize("out,fragment", [
    ("x.txt", "cannot write audio as '.txt'; the extension chooses the format: .wav, .flac, .ogg"),
    ("x", "cannot write audio as 'a file without an extension'"),
    ("nowhere/x.wav", "the folder 'nowhere' does not exist"),
    ("voice.wav/x.wav", "the folder 'voice.wav' does not exist"),
    ("sub", "is a folder"),
    ("tone.yaml", "is a file this run reads (tone.yaml)"),
    ("voice.wav", "is a file this run reads (voice.wav)"),
    ("link.wav", "is a file this run reads (voice.wav)"),
])
def test_bad_outputs_are_refused_before_rendering(hg, tone, tmp_path, out, fragment):
    (tmp_path / "sub").mkdir()
    os.symlink(tmp_path / "voice.wav", tmp_path / "link.wav")
    before = sorted(os.listdir(tmp_path))
    voice = (tmp_path / "voice.wav").read_bytes()
    proc = hg("run", tone, "--seconds", 0.1, "--out", out, cwd=tmp_path)
    assert_patch_error(proc, fragment)
    _nothing_new(tmp_path, before)
    assert (tmp_path / "voice.wav").read_bytes() == voice and tone.read_text() == TONE


@pytest.mark.parametrize("probes,fragment", [
    ("p.txt", "--probes 'p.txt': the probes are written as .npz; name a FILE.npz"),
    (os.devnull, "the probes are written as .npz"),
    ("patch.npz", "is a file this run reads (tone.yaml)"),
    ("fifo.npz", "exists and is not a regular file"),
    ("out.wav.npz", None),
])
def test_bad_probe_paths_are_refused(hg, tone, tmp_path, probes, fragment):
    os.symlink(tone, tmp_path / "patch.npz")
    os.mkfifo(tmp_path / "fifo.npz")
    if fragment is None:                      # a name is used exactly as given, not with .npz added
        proc = hg("run", tone, "--seconds", 0.1, "--probe", "tone.out", "--probes", probes, "--quiet", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        assert np.load(tmp_path / probes)["tone.out"].shape == (800,)
        assert not (tmp_path / (probes + ".npz")).exists()
        return
    before = sorted(os.listdir(tmp_path))
    proc = hg("run", tone, "--seconds", 0.1, "--probe", "tone.out", "--probes", probes, cwd=tmp_path)
    assert_patch_error(proc, fragment)
    _nothing_new(tmp_path, before)


@pytest.mark.parametrize("seconds", ["nan", "inf", "-inf", "0", "-1", "1e-9"])
def test_seconds_must_be_a_positive_finite_length(hg, tone, tmp_path, seconds):
    proc = hg("run", tone, f"--seconds={seconds}", "--out", "x.wav", cwd=tmp_path)
    assert_patch_error(proc, "--seconds")
    assert "expected a positive, finite number of seconds" in proc.stderr or "less than one sample" in proc.stderr
    assert not (tmp_path / "x.wav").exists()


def test_formats_by_extension_and_subtype(hg, tone, tmp_path):
    written = {}
    for out, subtype in (("a.wav", None), ("b.wav", "PCM_16"), ("c.wav", "pcm_24"), ("d.flac", None), ("e.ogg", None)):
        proc = hg("run", tone, "--seconds", 0.5, "--out", out, "--quiet", *(("--subtype", subtype) if subtype else ()),
                  cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        written[out] = soundfile.info(tmp_path / out)
        assert written[out].frames == 4000 and written[out].samplerate == 8000 and written[out].channels == 2
    assert [written[k].subtype for k in ("a.wav", "b.wav", "c.wav", "d.flac", "e.ogg")] == \
        ["FLOAT", "PCM_16", "PCM_24", "PCM_24", "VORBIS"]
    assert [written[k].format for k in ("a.wav", "d.flac", "e.ogg")] == ["WAV", "FLAC", "OGG"]
    proc = hg("run", tone, "--seconds", 0.5, "--out", "f.flac", "--subtype", "FLOAT", cwd=tmp_path)
    assert_patch_error(proc, "FLAC files cannot hold subtype FLOAT")
    proc = hg("run", tone, "--seconds", 0.5, "--out", "g.mp3", "--quiet", cwd=tmp_path)
    if "MP3" in soundfile.available_formats():          # libsndfile ≥ 1.1 writes MPEG layer III
        assert proc.returncode == 0 and soundfile.info(tmp_path / "g.mp3").format == "MP3"
    else:                                               # never a WAV under an .mp3 name
        assert_patch_error(proc, "cannot write audio as '.mp3'")
        assert not (tmp_path / "g.mp3").exists()
