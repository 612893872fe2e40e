"""Each uniform lattice's stencil has its interior loop vectorised, by the compiler's own account
(benchmarks/vectorised.py reads LLVM's optimised IR, the assembly and the loop-vectorize remarks;
issue 25, item 3), and the check sees a loop that is not vectorised."""
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest
from numba import njit

from project_env import ROOT

TOOL = ROOT / "benchmarks" / "vectorised.py"


def _tool():
    spec = importlib.util.spec_from_file_location("hg_benchmarks_vectorised", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


VEC = _tool()


@njit
def _string(x, xo, a, c):
    for i in range(1, x.shape[0] - 1):
        xo[i] = a * x[i] - xo[i] + c * (x[i - 1] + x[i + 1])


@njit
def _sheet(x, xo, a, c):
    rows, cols = x.shape
    for r in range(1, rows - 1):
        for j in range(1, cols - 1):
            xo[r, j] = a * x[r, j] - xo[r, j] + c * ((x[r - 1, j] + x[r + 1, j]) + (x[r, j - 1] + x[r, j + 1]))


@njit
def _recurrence(x, a):
    for i in range(1, x.shape[0]):
        x[i] = a * x[i - 1] + x[i]          # each cell needs the one just written: not vectorisable


@njit
def _axpy(x, y, a):
    for i in range(x.shape[0]):
        y[i] += a * x[i]                    # vectorised, but two loads a store: no stencil


def _loops(fn, *args):
    fn(*args)
    sig = fn.signatures[0]
    return VEC.kernel_loops(fn.inspect_llvm(sig), fn.overloads[sig].fndesc.mangled_name)


def test_the_check_tells_a_vectorised_stencil_from_what_is_not_one():
    x = np.zeros(64)
    string = _loops(_string, x, x.copy(), 1.9, 0.05)
    assert any(VEC.is_interior(lp, 1) for lp in string), string
    assert not any(VEC.is_interior(lp, 2) for lp in string)          # 4 loads a store: not a 5-point stencil
    sheet = _loops(_sheet, np.zeros((8, 8)), np.zeros((8, 8)), 1.9, 0.05)
    assert any(VEC.is_interior(lp, 2) for lp in sheet), sheet
    assert all(lp["blocks"] < 10 for lp in sheet)                     # innermost loops only, not the row loop
    recurrence = _loops(_recurrence, x, 0.5)
    assert recurrence and all(lp["width"] == 1 for lp in recurrence), recurrence
    axpy = _loops(_axpy, x, x.copy(), 0.5)
    assert any(lp["width"] > 1 for lp in axpy) and not any(VEC.is_interior(lp, 1) for lp in axpy), axpy


def test_demangle_and_remarks():
    assert VEC.demangle("_ZN11hapticgraph6blocks10massspring8stencils10sheet_stepB2v5B42c8tJTIeFIjxE5Arr") \
        == "hapticgraph.blocks.massspring.stencils.sheet_step"
    got = VEC.remark_summary("remark: <unknown>:0:0: vectorized loop (vectorization width: 4, interleaved count: 4)\n"
                             "remark: <unknown>:0:0: loop not vectorized: cannot identify array bounds\n"
                             "remark: <unknown>:0:0: loop not vectorized: cannot identify array bounds\n")
    assert got == {"vectorized": ["vectorized loop (vectorization width: 4, interleaved count: 4)"],
                   "not vectorized": {"loop not vectorized: cannot identify array bounds": 2}}


@pytest.mark.parametrize("name,dims", [("string_30000.yaml", 1), ("sheet_32.yaml", 2), ("sheet_150.yaml", 2),
                                       ("cube_20.yaml", 3)])
def test_each_stencils_interior_loop_is_vectorised(name, dims):
    report = VEC.analyse(ROOT / "benchmarks" / name)
    assert report["dims"] == dims
    assert report["vectorised"], VEC.show(report)
    for loop in report["interior"]:           # the machine code of that function has packed arithmetic too
        assert report["asm"][loop["function"]]["width"] >= 2, VEC.show(report)


def test_a_kernel_compiled_without_the_loop_vectoriser_fails_the_check(tmp_path):
    """The helpers' machine code a vectorising run left in the shared cache is not used by a run
    that turned the vectoriser off (the cache key names numba's code-generation settings)."""
    def check(**settings):
        env = {**os.environ, "HAPTICGRAPH_SHARED_CACHE": str(tmp_path / "shared"), **settings}
        return subprocess.run([sys.executable, str(TOOL), str(ROOT / "benchmarks" / "sheet_32.yaml")],
                              capture_output=True, text=True, env=env, timeout=600)
    first = check()
    assert first.returncode == 0, first.stdout + first.stderr
    proc = check(NUMBA_LOOP_VECTORIZE="0")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "interior loop NOT VECTORISED" in proc.stdout


def test_the_kernel_built_ahead_of_time_has_the_same_packed_loops():
    """A warm run loads the extension module numba.pycc built (graph/aot.py), not the JIT's code."""
    report = VEC.analyse(ROOT / "benchmarks" / "sheet_32.yaml")
    VEC.check_aot(report)
    assert report["aot"] is not None, "no extension module built (objdump or the C toolchain missing?)"
    assert report["vectorised"], VEC.show(report)
    for loop in report["interior"]:
        assert report["aot"][loop["function"]]["width"] >= 2
