"""The generated kernel: one readable module per patch, cached under a hash, dumped on request."""
import os
import subprocess
import sys

import numpy as np

from hapticgraph.graph.kernel import CompiledKernel, generate
from hapticgraph.graph.patch import load
from hapticgraph.graph.program import Program


def test_kernel_is_readable_and_cached(patches_dir, tmp_path, monkeypatch):
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(tmp_path / "cache"))
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    k1 = CompiledKernel(prog)
    assert os.path.dirname(os.path.dirname(k1.path)) == str(tmp_path / "cache")
    src = open(k1.path).read()
    # one sample loop; every output then every update in schedule order; literals baked in
    assert src.count("for i in range(n):") == 1
    assert src.index("delay_output(") < src.index("lowpass_output(") < src.index("delay_update(")
    assert "(0.25, 0.5, 0.25, )" in src and "t = t0 + i" in src
    assert "def kernel(n, t0, state, live, coef, rec, ext" in src and src == k1.source
    k2 = CompiledKernel(Program(load(patches_dir / "karplus_strong.yaml")))
    assert k2.path == k1.path
    # another parameter value is another source, so another file
    other = CompiledKernel(Program(load(patches_dir / "karplus_strong.yaml", overrides=["loop.length=50"])))
    assert other.path != k1.path


def test_source_hash_covers_block_functions(patches_dir):
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    source, fns = generate(prog)
    names = {f.__qualname__ for f in fns}
    assert {"Delay.output", "Delay.update", "Lowpass.output", "Pluck.output"} <= names


def test_dump_prints_the_kernel_path(patches_dir, tmp_path):
    env = {**os.environ, "HAPTICGRAPH_DUMP": "1", "HAPTICGRAPH_CACHE": str(tmp_path / "c")}
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "run", str(patches_dir / "karplus_strong.yaml"),
                           "--seconds", "0.01", "--out", str(tmp_path / "o.wav"), "--quiet"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    line = [ln for ln in proc.stderr.splitlines() if "kernel for" in ln][0]
    path = line.split(" is ")[-1]
    assert path.startswith(str(tmp_path / "c")) and os.path.isfile(path)


def test_state_persists_across_chunks(patches_dir):
    """Rendering in chunks of any size gives the same samples as one long call."""
    patch = load(patches_dir / "karplus_strong.yaml")
    one = Program(patch)
    k = CompiledKernel(one)
    whole = np.zeros((3000, len(one.records)))
    k.run(0, whole, np.zeros((3000, 0)))
    two = Program(load(patches_dir / "karplus_strong.yaml"))
    k2 = CompiledKernel(two)
    parts = np.zeros_like(whole)
    start = 0
    for size in (1, 7, 64, 1000, 1928):
        k2.run(start, parts[start:start + size], np.zeros((size, 0)))
        start += size
    np.testing.assert_array_equal(whole, parts)


def test_live_parameter_change_without_recompiling(patches_dir):
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    k = CompiledKernel(prog)
    rec = np.zeros((100, len(prog.records)))
    k.run(0, rec, np.zeros((100, 0)))
    prog.set_param("mic", "gain", 0.0)
    k.run(100, rec, np.zeros((100, 0)))
    assert np.all(rec == 0.0)


PLUGIN = '''
import math
from hapticgraph.blocks import Block, Out, Param


class Chord(Block, name="chord_test"):
    """out = Σ gains[i] (gains from derive, scaled by the live level)."""
    y = Out(name="out")
    level = Param(1.0)

    @staticmethod
    def derive(p, fs):
        return {"gains": [p.level, 2.0 * p.level, 3.0 * p.level], "bias": 0.5 * p.level}

    @staticmethod
    def output(gains, bias):
        return gains[0] + gains[1] + gains[2] + bias
'''


def test_control_rate_rederive_updates_scalar_and_array_coefficients(tmp_path):
    (tmp_path / "chord.py").write_text(PLUGIN)
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [chord.py]\nblocks:\n  c: {type: chord_test}\nconnect: []\n")
    for engine in ("compiled", "python"):
        from hapticgraph.graph.engine import make_runner
        prog = Program(load(tmp_path / "p.yaml"), probes=["c.out"])
        runner = make_runner(prog, engine)
        rec = np.zeros((4, 1))
        runner.run(0, rec, np.zeros((4, 0)))
        assert np.all(rec[:, 0] == 6.5)
        prog.set_param("c", "level", 2.0)      # derive reads a live parameter: coefficients re-derived
        runner.run(4, rec, np.zeros((4, 0)))
        assert np.all(rec[:, 0] == 13.0), engine
