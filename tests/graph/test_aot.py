"""Kernels built ahead of time (graph/aot.py): the same numbers as numba's JIT, sample for sample;
a warm start imports neither numba nor llvmlite; arguments of other types go to numba."""
import os
import subprocess
import sys

import numpy as np
import pytest

from project_env import PATCHES, ROOT
import hapticgraph
from hapticgraph.devices import open_drivers
from hapticgraph.graph import aot
from hapticgraph.graph.kernel import CompiledKernel
from hapticgraph.graph.patch import load
from hapticgraph.graph.program import Program

# one of each kind: a device and a bow, lattices and couplings, a hammer, voices and MIDI, delay
# lines and junctions (every patch, 20 of them: `-k test_aot` with HAPTICGRAPH_AOT_ALL=1; fewer
# here so the suite stays well inside CI's 20 minutes)
CHOSEN = ["fig7_bowed_string", "babe_is_sleeping", "piano_hammer", "poly_strings", "string_bound_implicit"]
EVERY = os.environ.get("HAPTICGRAPH_AOT_ALL") == "1"
SAMPLES = 3000


@pytest.fixture(scope="module")
def native_cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("native"))


def _render(path, probes, cache, native, monkeypatch):
    monkeypatch.setenv("HAPTICGRAPH_CACHE", cache)
    monkeypatch.setenv("HAPTICGRAPH_AOT", "1" if native else "0")
    patch = load(path)
    kernel = CompiledKernel(Program(patch, probes, open_drivers(patch)))
    assert isinstance(kernel.fn, aot.NativeKernel) == native, type(kernel.fn)
    return hapticgraph.render(load(path), SAMPLES / patch.rate, probes=probes, chunk=1000)


@pytest.mark.parametrize("path", [p for p in PATCHES if EVERY or p.stem in CHOSEN], ids=lambda p: p.stem)
def test_native_kernel_equals_numba_jit_bit_for_bit(path, native_cache, monkeypatch):
    patch = load(path)
    probes = [f"{name}.{port.name}" for name, inst in patch.blocks.items() for port in inst.outputs]
    jit = _render(path, probes, os.environ["HAPTICGRAPH_CACHE"], False, monkeypatch)
    native = _render(path, probes, native_cache, True, monkeypatch)
    assert np.array_equal(native.audio, jit.audio)
    for k in probes:
        assert np.array_equal(native.probes[k], jit.probes[k]), k
    assert any(np.any(v != 0) for v in [native.audio, *native.probes.values()])     # not vacuous


def test_arguments_of_other_types_go_to_numba(native_cache, monkeypatch, patches_dir):
    """A strided `rec` (the module would read it as contiguous) and a float t0 are numba's."""
    monkeypatch.setenv("HAPTICGRAPH_CACHE", native_cache)
    monkeypatch.setenv("HAPTICGRAPH_AOT", "1")
    prog = Program(load(patches_dir / "karplus_strong.yaml"))
    kernel = CompiledKernel(prog)
    assert isinstance(kernel.fn, aot.NativeKernel) and kernel.fn.dispatcher is None
    start = (prog.state.copy(), prog.live.copy(), prog.coef.copy(), [b.copy() for b in kernel.extra])
    wide = np.zeros((500, 2 * len(prog.records)))
    kernel.run(0, wide[:, ::2], np.zeros((500, len(prog.ext_columns))))
    assert kernel.fn.dispatcher is not None        # strided: numba's
    prog.state[:], prog.live[:], prog.coef[:] = start[:3]
    for b, saved in zip(kernel.extra, start[3]):
        b[:] = saved
    rec = np.zeros((500, len(prog.records)))
    kernel.run(0, rec, np.zeros((500, len(prog.ext_columns))))
    assert np.array_equal(rec, wide[:, ::2]) and np.any(rec != 0)
    fits = kernel.fn.fits
    args = (500, 0, prog.state, prog.live, prog.coef, rec, np.zeros((500, len(prog.ext_columns))), *kernel.extra)
    assert fits(args)
    for k, other in [(1, 0.0), (1, True), (0, np.int32(500)), (5, rec[:, None]), (5, rec.astype(np.float32)),
                     (5, rec[::2]), (5, np.zeros((3, 500)).T), (5, rec.tolist())]:
        assert not fits(args[:k] + (other,) + args[k + 1:]), (k, other)
    readonly = prog.coef.copy()
    readonly.flags.writeable = False
    assert not fits(args[:4] + (readonly,) + args[5:]) and not fits(args[:-1])


PROBE = """
import sys
from hapticgraph.cli import main
status = main(["run", "{patch}", "--seconds", "0.01", "--out", "{out}", "--quiet"])
print("STATUS", status)
print("HEAVY", ",".join(m for m in ("numba", "llvmlite", "scipy") if m in sys.modules))
"""


def _probe(patch, out, env):
    proc = subprocess.run([sys.executable, "-c", PROBE.format(patch=patch, out=out)], capture_output=True,
                          text=True, env=env, timeout=600, cwd=ROOT)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    lines = dict(ln.split(" ", 1) if " " in ln else (ln, "") for ln in proc.stdout.splitlines())
    return lines["STATUS"], [m for m in lines["HEAVY"].split(",") if m]


def test_a_warm_run_imports_no_numba(tmp_path):
    env = {**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / "cache"), "HAPTICGRAPH_AOT": "1"}
    patch = ROOT / "patches" / "fig8_pluck_damp.yaml"
    cold = _probe(patch, tmp_path / "cold.wav", env)
    assert cold[0] == "0" and "numba" in cold[1]
    warm = _probe(patch, tmp_path / "warm.wav", env)
    assert warm == ("0", [])
    import soundfile
    assert np.array_equal(soundfile.read(tmp_path / "cold.wav")[0], soundfile.read(tmp_path / "warm.wav")[0])
    entry = next((tmp_path / "cache").glob("kernel_*"))
    assert (entry / aot.library()).is_file() and not (entry / "__pycache__").exists()
    # HAPTICGRAPH_AOT=0: numba's JIT, its cache written into the same entry (and listed)
    assert _probe(patch, tmp_path / "jit.wav", {**env, "HAPTICGRAPH_AOT": "0"})[1][:1] == ["numba"]
    assert (entry / "__pycache__").is_dir() and _probe(patch, tmp_path / "again.wav", env) == ("0", [])
