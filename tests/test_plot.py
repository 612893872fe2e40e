"""`hapticgraph plot` writes a PNG of probe traces and a spectrogram."""
from hapticgraph.cli import main


def test_plot_writes_png(patches_dir, tmp_path, capsys):
    out = tmp_path / "ks.png"
    assert main(["plot", str(patches_dir / "karplus_strong.yaml"), "--probe", "loop.out", "--probe", "damp.out",
                 "--window", "0", "0.02", "--seconds", "0.3", "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_plot_bad_probe_is_usage_error(patches_dir, tmp_path, capsys):
    assert main(["plot", str(patches_dir / "karplus_strong.yaml"), "--probe", "loop.nope",
                 "-o", str(tmp_path / "x.png")]) == 2
    assert "probe 'loop.nope'" in capsys.readouterr().err
