"""audio_in: a WAV file beside the patch drives the patch, resampled to its rate."""
import numpy as np
import pytest

from hapticgraph import load, render
from hapticgraph.cli import main
from hapticgraph.devices.wav import write_wav


def test_audio_in_plays_the_file(tmp_path, write_patch):
    signal = np.sin(2 * np.pi * 441 * np.arange(2205) / 44100)
    write_wav(tmp_path / "voice.wav", np.stack([signal, -signal], axis=1), 44100)
    text = """
    hapticgraph: 1
    blocks:
      src: {type: audio_in, file: voice.wav, channel: 1, gain: 2.0}
    connect: []
    """
    p = load(write_patch(text))
    r = render(p, 0.1, probes=["src.out"])
    y = r.probes["src.out"]
    np.testing.assert_allclose(y[:2205], -2.0 * signal.astype(np.float32), atol=1e-6)
    assert np.all(y[2205:] == 0.0)
    looped = render(load(write_patch(text.replace("gain: 2.0", "gain: 1.0, loop: true"))), 0.1, probes=["src.out"])
    np.testing.assert_allclose(looped.probes["src.out"][2205:4410], looped.probes["src.out"][:2205])


def test_audio_in_is_resampled(tmp_path, write_patch):
    write_wav(tmp_path / "slow.wav", np.linspace(0, 1, 1001)[:, None], 1000)
    p = load(write_patch("hapticgraph: 1\nrate: 4000\nblocks:\n  src: {type: audio_in, file: slow.wav}\nconnect: []\n"))
    y = render(p, 1.0, probes=["src.out"]).probes["src.out"]
    assert y[2000] == pytest.approx(0.5, abs=1e-6)     # 0.5 s into a 1 s ramp


def test_missing_file_is_a_patch_error(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text("hapticgraph: 1\nblocks:\n  src:\n    type: audio_in\n    file: nowhere.wav\n")
    assert main(["check", str(path)]) == 2
    assert "p.yaml:5: block 'src' (audio_in): parameter 'file': no file 'nowhere.wav' beside the patch" in capsys.readouterr().err
