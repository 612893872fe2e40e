"""The streaming engine: `stream` hands a sink every block in order, `render` is the same loop with
an array sink, a stop request ends at a block boundary, and the runaway check watches the audio
and the forces, never the probes."""
import signal

import numpy as np
import pytest

from hapticgraph import load, render
from hapticgraph.graph.engine import ArraySink, SafetyStop, StopRequest, stream

TONE = """
hapticgraph: 1
rate: 8000
blocks:
  tone: {type: wavetable, shape: sine, frequency: 100.0, amplitude: 0.5}
  big: {type: constant, value: 5000.0}
  out: {type: audio_out, channels: 1}
connect:
  - tone.out -> out.ch0
"""


class Blocks:
    def start(self, rate, channels, probes, total):
        self.head, self.sizes, self.rows = (rate, channels, list(probes), total), [], []

    def write(self, block):
        self.sizes.append(block.shape[0])
        self.rows.append(block.copy())


def test_stream_hands_every_block_in_order(write_patch):
    patch = load(write_patch(TONE))
    sink = Blocks()
    done = stream(patch, 0.5, sink, probes=["tone.out"], chunk=1000)
    assert done.samples == 4000 and done.stopped is None and done.rate == 8000
    assert sink.head == (8000.0, 1, ["tone.out"], 4000) and sink.sizes == [1000] * 4
    rows = np.concatenate(sink.rows)
    assert rows.shape == (4000, 2)
    np.testing.assert_array_equal(rows[:, 0], rows[:, 1])          # the audio is the tone
    whole = render(load(write_patch(TONE)), 0.5, probes=["tone.out"], chunk=333)
    np.testing.assert_array_equal(whole.audio[:, 0], rows[:, 0])    # same samples, any chunk


def test_a_stop_request_ends_at_a_block_boundary(write_patch):
    patch = load(write_patch(TONE))
    stop = StopRequest()
    with pytest.raises(KeyboardInterrupt):
        stop.request(signal.SIGTERM)              # before rendering: nothing to keep, stop at once
    stop.signum = None

    class StopAfterTwo(Blocks):
        def write(self, block):
            super().write(block)
            if len(self.sizes) == 2:
                stop.request(signal.SIGTERM)      # rendering: only a request

    sink = StopAfterTwo()
    done = stream(patch, 10.0, sink, chunk=100, stop=stop)
    assert done.stopped == signal.SIGTERM and done.samples == 200 and sink.sizes == [100, 100]


def test_probes_are_never_a_runaway(write_patch):
    """A probe may watch anything — here a constant of 5000 — without stopping a healthy render."""
    patch = load(write_patch(TONE))
    r = render(patch, 0.1, probes=["big.out"], safety=True)
    assert r.audio.shape == (800, 1) and np.all(r.probes["big.out"] == 5000.0)
    loud = TONE.replace("amplitude: 0.5", "amplitude: 2000.0")
    free = render(load(write_patch(loud)), 0.1).audio[:, 0]
    first = int(np.argmax(np.abs(free) > 1e3))
    assert first > 0
    with pytest.raises(SafetyStop, match=rf"runaway: out.ch0 reached .* at {first / 8000:.4f} s") as info:
        render(load(write_patch(loud)), 0.1, safety=True)    # the audio is: stopped where it passed 1e3
    np.testing.assert_array_equal(info.value.result.audio[:, 0], free[:first])


def test_array_sink_keeps_what_was_written():
    sink = ArraySink()
    sink.start(100.0, 2, ["p"], 10)
    sink.write(np.arange(12.0).reshape(4, 3))

    class Done:
        rate, compile_seconds, run_seconds = 100.0, 0.0, 0.0
    r = sink.result(Done)
    assert r.audio.shape == (4, 2) and list(r.probes["p"]) == [2.0, 5.0, 8.0, 11.0]


def _run_on_a_terminal(args):
    """Run hapticgraph with stderr on a pseudo-terminal 100 columns wide; what the terminal showed."""
    import fcntl
    import os
    import pty
    import select
    import struct
    import subprocess
    import sys
    import termios
    import time
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", *map(str, args)], stderr=slave,
                            stdout=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    os.close(slave)
    shown = b""
    deadline = time.monotonic() + 300
    while True:
        if not select.select([master], [], [], max(0.0, deadline - time.monotonic()))[0]:
            proc.kill()                      # past the deadline: a hang fails the test instead of the suite
            break
        try:
            chunk = os.read(master, 1 << 16)
        except OSError:                      # EIO: the child closed the terminal
            break
        if not chunk:
            break
        shown += chunk
    os.close(master)
    assert proc.wait(timeout=300) == 0, shown
    return shown.decode("utf-8", "replace")


def test_progress_bar_on_a_terminal_only(patches_dir, tmp_path):
    patch = patches_dir / "karplus_strong.yaml"
    shown = _run_on_a_terminal(["run", patch, "--seconds", 60, "--out", tmp_path / "a.wav"])
    assert "rendering Karplus-Strong string:" in shown and "/2.65M" in shown and " samples/s]" in shown
    quiet = _run_on_a_terminal(["run", patch, "--seconds", 60, "--out", tmp_path / "b.wav", "--quiet"])
    assert "rendering" not in quiet and "samples/s" not in quiet
    from hapticgraph.graph.progress import NoBar, progress_bar
    assert isinstance(progress_bar(1000, "x", " samples"), NoBar)     # pytest's stderr is no terminal


def test_a_patch_with_nothing_to_keep_still_renders(write_patch):
    r = render(load(write_patch("hapticgraph: 1\nblocks:\n  g: {type: gain}\nconnect: []\n")), 0.01)
    assert r.audio.shape == (441, 0) and r.probes == {}
