"""Subnormal numbers are flushed to zero while a kernel runs, in the compiled kernel, the
ahead-of-time kernel and the interpreter alike (graph/denormals.py, graph/fpenv.py), and the
caller's floating-point mode is back when the run returns. Without it a damped instrument that
has gone quiet costs 35 times more a sample (benchmarks/realtime.py, issue 25 item 7)."""
import numpy as np
import pytest

import hapticgraph
from hapticgraph.graph import codegen, denormals, fpenv
from hapticgraph.graph.cachekey import kernel_key
from hapticgraph.graph.patch import load

pytestmark = pytest.mark.skipif(not denormals.SUPPORTED, reason="flush-to-zero is set on x86-64 Linux only")

SMALLEST_NORMAL = np.finfo(np.float64).tiny            # 2.2250738585072014e-308

# 3e-308 · 0.5 is below the smallest normal (flush-to-zero: 0); 1e-310 is subnormal as it is
# read (denormals-are-zero: 0 × 1.0); 1e-300 · 0.5 is normal and stays (each mic at the centre
# passes gain·√½ to its left channel).
PATCH = """
hapticgraph: 1
rate: 1000
blocks:
  small: {type: constant, value: 3e-308}
  tiny: {type: constant, value: 1e-310}
  fine: {type: constant, value: 1e-300}
  a: {type: mic, gain: 0.5, pan: 0.0}
  b: {type: mic, gain: 1.0, pan: 0.0}
  c: {type: mic, gain: 0.5, pan: 0.0}
  out: {type: audio_out, channels: 3}
connect:
  - small.out -> a.in
  - tiny.out -> b.in
  - fine.out -> c.in
  - a.left -> out.ch0
  - b.left -> out.ch1
  - c.left -> out.ch2
"""


def _ieee(x, y):
    return x * y


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_subnormals_are_flushed_inside_a_run_and_only_there(engine, write_patch):
    assert _ieee(3e-308, 0.5) != 0.0                     # the caller's mode: IEEE, gradual underflow
    out = hapticgraph.render(load(write_patch(PATCH)), 0.01, engine=engine).audio
    assert out.shape == (10, 3)
    assert np.all(out[:, 0] == 0.0) and np.all(out[:, 1] == 0.0)
    assert np.allclose(out[:, 2], 0.5e-300 * np.sqrt(0.5), rtol=1e-15, atol=0)   # equal-power pan, centre
    assert _ieee(3e-308, 0.5) > 0.0 and _ieee(1e-310, 1.0) == 1e-310     # put back after the run
    assert np.array([3e-308])[0] * 0.5 != 0.0


def test_a_decayed_sheet_rests_at_zero_in_both_engines(write_patch):
    """A damped sheet left ringing decays below the smallest normal: flushed, its positions come
    to rest at exactly zero, and the engines agree on every sample on the way."""
    path = write_patch("""
        hapticgraph: 1
        rate: 2000
        blocks:
          plate: {type: lattice, shape: [4, 5], mass: 0.001, tension: 1000.0, damping: 0.5}
          hit: {type: pluck, time: 0.0, force: 1.0, duration: 0.002}
          mic: {type: mic, gain: 1.0, pan: 0.0}
          out: {type: audio_out}
        connect:
          - hit.out -> plate[1, 2].force
          - plate[2, 3].position -> mic.in
          - mic.left -> out.left
          - mic.right -> out.right
    """)
    # the slowest mode decays as exp(−γ/(2m)·t) = exp(−250 t): below 2.2e-308 (e^−708) in ~2.9 s
    seconds = 4.0
    probes = ["plate[2, 3].position"]
    fast = hapticgraph.render(load(path), seconds, engine="compiled", probes=probes)
    slow = hapticgraph.render(load(path), seconds, engine="python", probes=probes)
    assert np.array_equal(fast.audio, slow.audio)
    x = fast.probes[probes[0]]
    assert np.max(np.abs(x[:200])) > 1e-6                                   # it rang
    quiet = np.flatnonzero(x != 0.0)[-1] + 1
    assert quiet < len(x) - 1000                                            # then rests at 0
    nonzero = np.abs(x[x != 0.0])
    assert np.all(nonzero >= SMALLEST_NORMAL)                               # never subnormal


def test_the_cache_key_holds_the_flush_intrinsics_file(tmp_path):
    """The kernel imports graph/fpenv.py's intrinsics by name, so their file is part of what its
    machine code depends on: a kernel key changes with that file's content."""
    files = codegen.support_files()
    assert fpenv.__file__ in files
    copy = tmp_path / "fpenv.py"
    copy.write_bytes(open(fpenv.__file__, "rb").read())
    before = kernel_key("source", [], [copy])
    copy.write_bytes(copy.read_bytes() + b"\n# changed\n")
    assert kernel_key("source", [], [copy]) != before
