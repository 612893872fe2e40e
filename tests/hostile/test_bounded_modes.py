"""Issue 21 item 2: modes of large instruments. `modes` (and `plot --mode`) solve with a sparse
symmetric eigen-solver in shift-invert mode when the network is large or the count small against
it, densely only where that is cheaper; a count whose solve would pass the memory budget is
refused (exit 2) with the largest count that fits. Every child runs under the hostile tests'
address-space limit (1.5 GB): `modes --count 20000` of a 20,000-cell sheet used to allocate a dense
20,000² matrix (3.2 GB) and die with MemoryError, `plot --mode 1` of a 150 × 150 sheet took 12 GB."""
import math
import re

import numpy as np
import pytest

from hostile_env import assert_patch_error

from hapticgraph.graph.modes import MEMORY_BUDGET, eigen_omegas, solver_plan
from hapticgraph.graph.family import groups
from hapticgraph.graph.patch import load

SHEET = """hapticgraph: 1
rate: 44100
blocks:
  sheet: {type: lattice, shape: [ROWS, COLS], mass: 0.0002, tension: 3400.0, boundary: fixed}
"""
STRING = """hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [CELLS], mass: 0.0001, tension: 100000.0, boundary: fixed}
"""


def _sheet(rows, cols):
    return SHEET.replace("ROWS", str(rows)).replace("COLS", str(cols))


def _closed_form_sheet(rows, cols, count, tension=3400.0, mass=0.0002, rate=44100.0):
    """The fixed-rim mesh's modes f_d [Hz], lowest first (the separable closed form)."""
    k1, k2 = np.meshgrid(np.arange(1, rows + 1), np.arange(1, cols + 1), indexing="ij")
    w2 = 4 * tension / mass * (np.sin(k1 * np.pi / (2 * (rows + 1))) ** 2 + np.sin(k2 * np.pi / (2 * (cols + 1))) ** 2)
    return np.sort(rate / np.pi * np.arcsin(np.sqrt(w2.ravel()) / (2 * rate)))[:count]


def _network(write_patch, text):
    patch = load(write_patch(text))
    (family, members), = groups(patch.blocks)
    return family.build(members, patch.rate, False)


@pytest.mark.parametrize("text", [_sheet(40, 45), STRING.replace("CELLS", "3000")])
def test_sparse_and_dense_agree_where_both_run(write_patch, text):
    net = _network(write_patch, text)
    dense, how = eigen_omegas(net, 20, method="dense")
    assert how == "dense"
    sparse, how = eigen_omegas(net, 20, method="shift-invert")
    assert how == "shift-invert"
    assert np.all(np.abs(sparse - dense) <= 0.002 * dense)
    assert np.all(np.abs(sparse - dense) <= 1e-7 * dense)      # in fact to round-off
    assert eigen_omegas(net, 20)[1] == "shift-invert"             # 20 of 1,800 or 3,000: sparse is cheaper
    assert eigen_omegas(net, 1500)[1] == "dense"                  # most of them: dense is


def test_the_plan_follows_the_budget():
    assert solver_plan(500, 2_500, 20)[0] == "dense"
    assert solver_plan(22_500, 112_500, 20)[0] == "shift-invert"
    assert solver_plan(4_000, 20_000, 3_000)[0] == "dense"
    with pytest.raises(ValueError) as err:
        solver_plan(20_000, 100_000, 20_000)
    largest = int(re.search(r"at most ([0-9,]+) fit", str(err.value)).group(1).replace(",", ""))
    assert 100 < largest < 20_000
    assert solver_plan(20_000, 100_000, largest)[2] <= MEMORY_BUDGET
    with pytest.raises(ValueError):
        solver_plan(20_000, 100_000, largest + 1)


def test_a_count_past_the_budget_is_refused_with_the_largest_that_fits(hg, write_patch):
    path = write_patch(_sheet(100, 200))
    proc = hg("modes", path, "--count", 20000, timeout=120)
    assert_patch_error(proc, "--count 20000")
    assert re.search(r"at most [0-9,]+ fit", proc.stderr), proc.stderr


@pytest.mark.parametrize("text,closed", [
    (_sheet(150, 150), _closed_form_sheet(150, 150, 20)),
    (STRING.replace("CELLS", "30000"),
     44100 / np.pi * np.arcsin(np.sqrt(4 * 1e5 / 1e-4) * np.sin(np.arange(1, 21) * np.pi / (2 * 30001)) / (2 * 44100))),
])
def test_twenty_lowest_modes_of_large_instruments(hg, write_patch, text, closed):
    """Under the 1.5 GB limit, in a child: the closed form of the fixed string and sheet to 0.2 %."""
    proc = hg("modes", write_patch(text), "--count", 20, "--json", timeout=240)
    assert proc.returncode == 0, proc.stderr
    import json
    (net,) = json.loads(proc.stdout)["networks"]
    assert net["method"] == "shift-invert"
    f = np.array(net["frequencies"])
    assert f.shape == (20,) and np.all(np.abs(f - closed) <= 0.002 * closed), (f, closed)


def test_plot_mode_of_a_large_sheet(hg, write_patch, tmp_path):
    pytest.importorskip("matplotlib", reason="matplotlib is in the plot extra (and dev): pip install -e '.[dev]'")
    path = write_patch(_sheet(150, 150))
    proc = hg("plot", path, "--mode", 3, "-o", tmp_path / "m.png", timeout=240)
    assert proc.returncode == 0, proc.stderr
    f3 = _closed_form_sheet(150, 150, 3)[2]
    shown = float(re.search(r"mode 3 at ([0-9.]+) Hz", proc.stdout).group(1))
    assert math.isclose(shown, f3, rel_tol=2e-3), (shown, f3)
