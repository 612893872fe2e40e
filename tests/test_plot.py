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


def test_probe_quantities_and_units_come_from_the_declarations(patches_dir):
    from hapticgraph import load
    from hapticgraph.plot import probe_label, quantity_of
    fig8 = load(patches_dir / "fig8_pluck_damp.yaml")
    assert quantity_of(fig8, "tip.force") == ("force", "N")
    assert quantity_of(fig8, "finger.x") == ("position", "m")
    assert quantity_of(fig8, "finger.v") == ("velocity", "m/s")
    assert quantity_of(fig8, "xs.out") == ("displacement", "m")
    assert probe_label(fig8, "tip.force") == "tip.force\nforce [N]"
    lattice = load(patches_dir / "cymatic_string.yaml")
    assert quantity_of(lattice, "str[50].velocity") == ("velocity", "m/s")
    assert quantity_of(lattice, "str[3].force") == ("force", "N")
    assert quantity_of(lattice, "str.tension") == ("stiffness", "N/m")      # a live parameter
    ks = load(patches_dir / "karplus_strong.yaml")
    assert probe_label(ks, "loop.out") == "loop.out"                         # a delay declares no unit


def test_plot_axes_carry_quantities_and_units(patches_dir, tmp_path, monkeypatch, capsys):
    import matplotlib.figure
    drawn = []
    real_savefig = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        drawn.append([(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes])
        return real_savefig(fig, *args, **kwargs)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    assert main(["plot", str(patches_dir / "fig8_pluck_damp.yaml"), "--seconds", "0.1", "--probe", "finger.x",
                 "--probe", "tip.force", "-o", str(tmp_path / "f.png")]) == 0
    (labels,) = drawn
    assert labels[0] == ("time [s]", "finger.x\nposition [m]")
    assert labels[1] == ("time [s]", "tip.force\nforce [N]")
    assert labels[2] == ("time [s]", "audio\nfrequency [Hz]")
    assert labels[3][1] == "power [dB]"                                      # the spectrogram's colour bar


def test_plot_without_matplotlib_is_one_line(patches_dir, tmp_path):
    import subprocess
    import sys
    code = ("import sys; sys.modules['matplotlib'] = None\n"
            "from hapticgraph.cli import main\n"
            f"sys.exit(main(['plot', {str(patches_dir / 'karplus_strong.yaml')!r}, '--probe', 'loop.out', "
            f"'-o', {str(tmp_path / 'x.png')!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert proc.stderr == 'hapticgraph: plot needs matplotlib: pip install "hapticgraph[plot]"\n'
    assert not (tmp_path / "x.png").exists()
