"""Mode shapes (`hapticgraph plot --mode`): a fixed string's modes are sines, at the frequencies
`modes` predicts, numbered from 1 as `modes` numbers them."""
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


@pytest.mark.parametrize("mode", [1, 2, 5])
def test_fixed_string_modes_are_sines(write_patch, mode):
    patch = load(write_patch(STRING))
    freq, shape = mode_shape(patch, "str", mode)
    i = np.arange(30)
    expect = np.sin(np.pi * mode * (i + 1) / 31)       # mode 1: half a sine, no node inside
    expect /= expect[np.argmax(np.abs(expect))]
    np.testing.assert_allclose(shape, expect, atol=1e-9)
    assert freq == pytest.approx(modal_frequencies(patch, count=mode)["str"][mode - 1], rel=1e-9)


def test_cut_cells_are_nan_and_locked_are_still(write_patch):
    patch = load(write_patch("hapticgraph: 1\nblocks:\n  p: {type: lattice, shape: [5, 6], cut: [[0, 0]], "
                             "lock: [[2, 3]], tension: 1000.0}\nconnect: []\n"))
    freq, shape = mode_shape(patch, "p", 1)
    assert shape.shape == (5, 6) and np.isnan(shape[0, 0]) and shape[2, 3] == 0.0 and freq > 0


def test_plot_mode_png(write_patch, tmp_path, capsys):
    path = write_patch(STRING)
    assert main(["plot", str(path), "--mode", "2", "-o", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["plot", str(path), "--mode", "99", "-o", str(tmp_path / "m.png")]) == 2
    assert "mode 99 does not exist" in capsys.readouterr().err
    assert main(["plot", str(path), "--mode", "30", "-o", str(tmp_path / "m.png")]) == 0   # the highest


def test_plot_mode_numbers_as_modes_does(write_patch, tmp_path, capsys):
    """`plot --mode N` is row N of `hapticgraph modes`: the same frequency; mode 0 is refused."""
    path = write_patch(STRING)
    assert main(["modes", str(path), "--count", "3"]) == 0
    rows = {int(line.split()[0]): float(line.split()[1]) for line in capsys.readouterr().out.splitlines()
            if line.strip() and line.split()[0].isdigit()}
    assert sorted(rows) == [1, 2, 3]
    for n in (1, 3):
        assert main(["plot", str(path), "--mode", str(n), "-o", str(tmp_path / "m.png")]) == 0
        printed = capsys.readouterr().out
        assert f"mode {n} at {rows[n]:.2f} Hz" in printed, printed
    assert main(["plot", str(path), "--mode", "0", "-o", str(tmp_path / "m0.png")]) == 2
    err = capsys.readouterr().err
    assert "numbered from 1" in err and "Traceback" not in err
    assert not (tmp_path / "m0.png").exists()
