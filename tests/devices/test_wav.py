"""Audio files through soundfile: formats by extension, the writer's temp-beside-and-rename, and
the audio_in reader that resamples as it streams (same samples as interpolating the whole file)."""
import os

import numpy as np
import pytest
import soundfile

from hapticgraph.devices import files
from hapticgraph.devices.files import ProbeWriter, WavInput
from hapticgraph.devices.wav import AudioFileError, AudioWriter, audio_format, write_wav


def test_formats_by_extension():
    assert audio_format("a.wav") == ("WAV", "FLOAT")
    assert audio_format("a.WAV", "pcm_16") == ("WAV", "PCM_16")
    assert audio_format("a.flac") == ("FLAC", "PCM_24")
    assert audio_format("a.ogg") == ("OGG", "VORBIS")
    for bad in ("a.txt", "a", "a.wav.bak"):
        with pytest.raises(AudioFileError, match="the extension chooses the format: .wav, .flac, .ogg"):
            audio_format(bad)
    with pytest.raises(AudioFileError, match="FLAC files cannot hold subtype FLOAT; they can hold .*PCM_16"):
        audio_format("a.flac", "FLOAT")


def test_writer_renames_into_place_and_clips_pcm(tmp_path):
    target = tmp_path / "x.wav"
    w = AudioWriter(target, 8000, 2, "PCM_16")
    assert not target.exists() and os.path.dirname(w.tmp) == str(tmp_path)
    w.write(np.array([[0.5, 2.0], [-3.0, 0.25]]))
    assert w.close() == 2 and target.exists() and not os.path.exists(w.tmp)
    data, rate = soundfile.read(target)
    assert rate == 8000 and data[0, 1] == pytest.approx(1.0, abs=1e-4) and data[1, 0] == -1.0
    assert w.peak == 3.0
    assert sorted(os.listdir(tmp_path)) == ["x.wav"]


def test_probe_writer_is_an_npz_numpy_reads(tmp_path):
    w = ProbeWriter(tmp_path / "p.npz", 1000.0, ["a.out", "c[1, 2].position"])
    blocks = [np.random.default_rng(k).normal(size=(n, 2)) for k, n in enumerate((5, 7, 1))]
    for b in blocks:
        w.write(b)
    assert w.close() == 13
    z = np.load(tmp_path / "p.npz")
    assert set(z.files) == {"rate", "a.out", "c[1, 2].position"} and z["rate"] == 1000.0
    whole = np.concatenate(blocks)
    np.testing.assert_array_equal(z["a.out"], whole[:, 0])
    np.testing.assert_array_equal(z["c[1, 2].position"], whole[:, 1])
    assert sorted(os.listdir(tmp_path)) == ["p.npz"]


def _whole_file_reference(data, file_rate, rate, t0, n, loop):
    """What audio_in played before streaming: the whole file interpolated to the patch rate."""
    if file_rate != rate and len(data) > 1:
        length = int(round(len(data) * rate / file_rate))
        signal = np.interp(np.arange(length) * file_rate / rate, np.arange(len(data)), data)
    else:
        signal = data
    idx = t0 + np.arange(n)
    if loop:
        return signal[idx % len(signal)]
    out = np.zeros(n)
    inside = idx < len(signal)
    out[inside] = signal[idx[inside]]
    return out


@pytest.mark.parametrize("file_rate,rate", [(3000, 4000), (4000, 4000), (48000, 1000), (7, 4000)])
@pytest.mark.parametrize("loop", [False, True])
@pytest.mark.parametrize("streamed", [False, True])
def test_streaming_resampler_matches_the_whole_file(tmp_path, monkeypatch, file_rate, rate, loop, streamed):
    data = np.random.default_rng(1).uniform(-1, 1, size=(1001, 2))
    path = tmp_path / "in.wav"
    soundfile.write(path, data, file_rate, subtype="DOUBLE")
    if streamed:                           # read from the file block by block, in small pieces
        monkeypatch.setattr(files, "IN_MEMORY_FRAMES", 10)
        monkeypatch.setattr(files, "MAX_SPAN", 37)
    d = WavInput(path, channel=1, loop=loop)
    assert (d.data is None) == streamed
    d.start(rate)
    t0 = 0
    for n in (1, 100, 513, 4096, 3000):
        ext = np.full((n, 1), 9.0)
        d.fill(t0, ext)
        np.testing.assert_array_equal(ext[:, 0], _whole_file_reference(data[:, 1], file_rate, rate, t0, n, loop),
                                      err_msg=f"t0={t0} n={n}")
        t0 += n
    d.stop()


def test_unreadable_inputs_are_value_errors(tmp_path):
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x00\x00\x44\xac\x00\x00"
                    b"\x00\x00\x00\x00\x00\x00\x10\x00data\x00\x00\x00\x00")       # 0 channels
    with pytest.raises(ValueError, match="bad.wav"):
        WavInput(bad)
    (tmp_path / "text.wav").write_text("not audio")
    with pytest.raises(ValueError, match="text.wav is not a readable audio file"):
        WavInput(tmp_path / "text.wav")
    write_wav(tmp_path / "one.wav", np.zeros((10, 1)), 8000)
    with pytest.raises(ValueError, match="has 1 channel"):
        WavInput(tmp_path / "one.wav", channel=1)
