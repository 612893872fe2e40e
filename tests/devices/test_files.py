"""audio_in: a WAV file beside the patch drives the patch, resampled to its rate; the sink of
`hapticgraph run` writes from a thread of its own, in order, and tells a failed write once."""
import errno

import numpy as np
import pytest
import soundfile

from hapticgraph import load, render
from hapticgraph.cli import main
from hapticgraph.devices.files import FileSink, OutputError
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


def _blocks(count, frames=1000, columns=3):
    """Blocks as the render hands them over: a column slice of a records buffer it reuses."""
    rec = np.zeros((frames, columns + 1))
    for k in range(count):
        rec[:, :columns] = k + np.arange(frames * columns).reshape(frames, columns) * 1e-6
        yield rec[:, :columns]


def test_the_sink_writes_in_order_from_its_thread_while_the_caller_reuses_its_buffer(tmp_path):
    """FileSink writes in a thread of its own: every block, in order, although the caller
    overwrites its view as soon as `write` returns; the probes' .npz the same."""
    sink = FileSink(tmp_path / "a.wav", tmp_path / "p.npz", 1000, 2, ["x"])
    expected = []
    for block in _blocks(12):
        expected.append(block.copy())
        sink.write(block)
    sink.drain()
    written, errors = sink.close()
    assert errors == [] and [n for _, n in written] == [12000, 12000]
    whole = np.concatenate(expected)
    audio, _ = soundfile.read(tmp_path / "a.wav", dtype="float32")
    np.testing.assert_array_equal(audio, whole[:, :2].astype(np.float32))
    np.testing.assert_array_equal(np.load(tmp_path / "p.npz")["x"], whole[:, 2])
    assert sink.peak == pytest.approx(float(np.abs(whole[:, :2].astype(np.float32)).max()))


@pytest.mark.parametrize("failing", [3, 11])
def test_a_failed_write_is_told_once_and_what_came_before_is_kept(tmp_path, monkeypatch, failing):
    """A write the thread could not do is raised by the next `write` or by `drain` (a failure in
    the last block too), and `close` does not tell it again; nothing after it is written,
    everything before it is."""
    sink = FileSink(tmp_path / "a.wav", None, 1000, 3, [])
    real, calls = sink.audio.write, []

    def write(part):
        calls.append(part.shape[0])
        if len(calls) == failing + 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(part)
    monkeypatch.setattr(sink.audio, "write", write)
    told = []
    try:                                  # as a render does: the first OutputError ends it
        for block in _blocks(12):
            sink.write(block)
        sink.drain()
    except OutputError as exc:
        told.append(str(exc))
    written, errors = sink.close()
    assert len(told) == 1 and "No space left on device; is the disk full?" in told[0] and errors == []
    assert written == [(str(tmp_path / "a.wav"), failing * 1000)]
    assert len(calls) == failing + 1                   # nothing tried after the failed block


def test_a_failure_no_one_was_told_of_is_an_error_at_close(tmp_path, monkeypatch):
    sink = FileSink(tmp_path / "a.wav", None, 1000, 3, [])
    monkeypatch.setattr(sink.audio, "write", lambda part: (_ for _ in ()).throw(OSError(errno.EFBIG, "File too large")))
    sink.write(next(_blocks(1)))
    written, errors = sink.close()
    assert written == [(str(tmp_path / "a.wav"), 0)]
    assert len(errors) == 1 and "File too large; is the disk full?" in errors[0]
