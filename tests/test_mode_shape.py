"""Mode shapes (`hapticgraph plot --mode`): a fixed string's modes are sines, at the frequencies
`modes` predicts."""
import numpy as np
import pytest

from hapticgraph import load
from hapticgraph.cli import main
from hapticgraph.graph.modes import mode_shape, modal_frequencies

STRING = """
hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [30], mass: 0.001, tension: 100000.0}
connect: []
"""


@pytest.mark.parametrize("mode", [0, 1, 4])
def test_fixed_string_modes_are_sines(write_patch, mode):
    patch = load(write_patch(STRING))
    freq, shape = mode_shape(patch, "str", mode)
    i = np.arange(30)
    expect = np.sin(np.pi * (mode + 1) * (i + 1) / 31)
    expect /= expect[np.argmax(np.abs(expect))]
    np.testing.assert_allclose(shape, expect, atol=1e-9)
    assert freq == pytest.approx(modal_frequencies(patch, count=mode + 1)["str"][mode], rel=1e-9)


def test_cut_cells_are_nan_and_locked_are_still(write_patch):
    patch = load(write_patch("hapticgraph: 1\nblocks:\n  p: {type: lattice, shape: [5, 6], cut: [[0, 0]], "
                             "lock: [[2, 3]], tension: 1000.0}\nconnect: []\n"))
    freq, shape = mode_shape(patch, "p", 0)
    assert shape.shape == (5, 6) and np.isnan(shape[0, 0]) and shape[2, 3] == 0.0 and freq > 0


def test_plot_mode_png(write_patch, tmp_path, capsys):
    path = write_patch(STRING)
    assert main(["plot", str(path), "--mode", "2", "-o", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["plot", str(path), "--mode", "99", "-o", str(tmp_path / "m.png")]) == 2
    assert "mode 99 does not exist" in capsys.readouterr().err
