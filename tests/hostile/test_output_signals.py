"""Issue 10 item 6: a kill, a Ctrl-C or a full disk loses nothing already made. `run` writes beside
its targets and renames into place; SIGTERM, SIGHUP and SIGINT leave a valid WAV (true RIFF sizes)
and probes holding everything rendered so far; a full disk (a file-size limit, which fails writes
with EFBIG as a full disk fails them with ENOSPC) gives a clear error and a readable partial file."""
import os
import resource
import signal
import struct
import subprocess
import sys
import time

import numpy as np
import pytest
import soundfile

MEMORY_LIMIT_MB = 1536          # as tests/hostile/conftest.py

KARPLUS = os.path.join(os.path.dirname(__file__), "..", "..", "patches", "karplus_strong.yaml")


def _child_limits(file_size=None):
    def apply():
        limit = MEMORY_LIMIT_MB << 20
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        if file_size is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)     # a write past the limit fails with EFBIG
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))
    return apply


def _hg(*args):
    return [sys.executable, "-m", "hapticgraph", *map(str, args)]


def _riff_sizes_are_true(path):
    with open(path, "rb") as f:
        head = f.read(12)
        size = os.path.getsize(path)
        assert head[:4] == b"RIFF" and head[8:12] == b"WAVE"
        assert struct.unpack("<I", head[4:8])[0] == size - 8
        while True:                       # walk the chunks to `data`: its size fits the file
            chunk = f.read(8)
            assert len(chunk) == 8, "no data chunk"
            kind, length = chunk[:4], struct.unpack("<I", chunk[4:])[0]
            if kind == b"data":
                assert f.tell() + length == size
                return length
            f.seek(length + (length & 1), 1)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_keeps_everything_rendered(tmp_path, signum):
    out = tmp_path / "take.wav"
    proc = subprocess.Popen(_hg("run", KARPLUS, "--seconds", 3000, "--out", out, "--probe", "loop.out"),
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_child_limits())
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:     # the first bytes of audio
            parts = [p for p in os.listdir(tmp_path) if p.startswith(".take.wav.") and p.endswith(".part")]
            if parts and os.path.getsize(tmp_path / parts[0]) > 1 << 20:
                break
            time.sleep(0.02)
        assert proc.poll() is None, proc.communicate()
        os.kill(proc.pid, signum)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signum, stderr        # the shells' convention: 130 for SIGINT
    assert "Traceback" not in stderr
    name = signal.Signals(signum).name
    assert f"hapticgraph: interrupted ({name}) after " in stderr
    info = soundfile.info(out)
    assert 0 < info.frames < 3000 * 44100 and info.samplerate == 44100 and info.subtype == "FLOAT"
    assert _riff_sizes_are_true(out) == 8 * info.frames
    assert f"{info.frames} samples written to {out}" in stderr
    audio, _ = soundfile.read(out)
    assert np.all(np.isfinite(audio)) and np.abs(audio).max() > 0.1
    probes = np.load(tmp_path / "take.npz")
    assert probes["loop.out"].shape == (info.frames,) and probes["rate"] == 44100
    assert sorted(os.listdir(tmp_path)) == ["take.npz", "take.wav"]         # no temporary file left


def test_a_full_disk_keeps_a_readable_partial_file(tmp_path):
    limit = 3 << 20
    out = tmp_path / "full.wav"
    proc = subprocess.run(_hg("run", KARPLUS, "--seconds", 60, "--out", out, "--quiet"), cwd=tmp_path,
                          capture_output=True, text=True, timeout=300, preexec_fn=_child_limits(limit))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"hapticgraph: error: cannot write {out}" in proc.stderr and "is the disk full?" in proc.stderr
    info = soundfile.info(out)
    assert 0 < info.frames < 60 * 44100 and os.path.getsize(out) <= limit
    assert _riff_sizes_are_true(out) == 8 * info.frames
    assert f"{info.frames} samples written to {out}" in proc.stderr
    partial, _ = soundfile.read(out, dtype="float32")
    whole = subprocess.run(_hg("run", KARPLUS, "--seconds", 1, "--out", tmp_path / "whole.wav", "--quiet"),
                           cwd=tmp_path, capture_output=True, text=True, timeout=300, preexec_fn=_child_limits())
    assert whole.returncode == 0, whole.stderr
    reference, _ = soundfile.read(tmp_path / "whole.wav", dtype="float32")
    n = min(len(partial), len(reference))
    np.testing.assert_array_equal(partial[:n], reference[:n])     # the samples before the failure
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".part")]
