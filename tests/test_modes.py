"""`hapticgraph modes PATCH [--count N] [--json] [--set ...]`: the command line of graph/modes.py."""
import json
import math
import pathlib
import subprocess
import sys

import pytest

from hapticgraph.cli import main
from hapticgraph.graph.modes import modal_frequencies

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too

STRING = ROOT / "patches" / "cymatic_string.yaml"


def f_string(T, m=2e-4, N=60, k=1, fs=44100.0):
    """Fixed string: ω = 2√(T/m)·sin(kπ/(2(N+1))), then the half-step correction."""
    w = 2 * math.sqrt(T / m) * math.sin(k * math.pi / (2 * (N + 1)))
    return fs / math.pi * math.asin(w / (2 * fs))


def test_table(capsys):
    assert main(["modes", str(STRING), "--count", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("str: 60 moving cells, 0 locked (dense); half-step scheme at 44100 Hz")
    rows = [line.split() for line in out[2:5]]
    assert [r[0] for r in rows] == ["1", "2", "3"]
    for k, r in enumerate(rows, 1):
        assert float(r[1]) == pytest.approx(f_string(144100.0, k=k), abs=1e-5)
    assert rows[0][3] == "1.0000"
    assert out[5] == "  note: damping ignored (lossless modes)"


def test_json_matches_the_function(capsys):
    assert main(["modes", str(STRING), "--json", "--count", "5"]) == 0
    doc = json.loads(capsys.readouterr().out)
    (net,) = doc["networks"]
    assert doc["rate"] == 44100.0
    assert net["name"] == "str" and net["cells"] == 60 and net["rigid"] == 0
    assert net["frequencies"] == modal_frequencies(str(STRING), 5)["str"]
    assert net["continuous"][0] < net["frequencies"][0]         # the scheme sounds a little sharp


def test_set_overrides_a_parameter(capsys):
    """A quarter of the tension: an octave down (to the correction's tiny difference)."""
    assert main(["modes", str(STRING), "--json", "--count", "1", "--set", "str.tension=36025"]) == 0
    f = json.loads(capsys.readouterr().out)["networks"][0]["frequencies"][0]
    assert f == pytest.approx(f_string(36025.0), rel=1e-9)
    assert f_string(144100.0) / f == pytest.approx(2.0, rel=1e-4)


def test_several_networks_and_a_joined_one(capsys):
    assert main(["modes", str(ROOT / "patches" / "string_drives_plate.yaml"), "--count", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("str + plate + bridge: 160 moving cells")


def test_free_network_prints_its_rigid_mode(write_patch, capsys):
    path = write_patch("""
    hapticgraph: 1
    blocks:
      a: {type: cell, mass: 0.01}
      b: {type: cell, mass: 0.01}
      s: {type: spring, a: a, b: b, tension: 1000.0}
      lone: {type: cell}
    connect: []
    """)
    assert main(["modes", str(path)]) == 0
    out = capsys.readouterr().out
    assert "a + b + s: 2 moving cells" in out and "lone: 1 moving cells" in out
    assert out.count("rigid") >= 4           # a rigid row and a note for each network
    # two equal masses on a spring: ω = √(2k/m)
    f = modal_frequencies(path, 2)["a + b + s"]
    assert f[0] == 0.0
    w = math.sqrt(2 * 1000.0 / 0.01)
    assert f[1] == pytest.approx(44100 / math.pi * math.asin(w / (2 * 44100)), rel=1e-9)


def test_patch_without_a_network(capsys):
    assert main(["modes", str(ROOT / "patches" / "karplus_strong.yaml")]) == 0
    assert "no mass-spring network" in capsys.readouterr().out


def test_driven_parameters_are_noted(write_patch, capsys):
    path = write_patch("""
    hapticgraph: 1
    blocks:
      k: {type: constant, value: 0.002}
      L: {type: lattice, shape: [5], mass: 0.001, tension: 1000.0}
    connect:
      - k.out -> L.mass
    """)
    assert main(["modes", str(path), "--count", "2"]) == 0
    assert "note: L.mass is driven by a connection; its patch value 0.001 kg is used" in capsys.readouterr().out


def test_patch_errors_exit_2_with_file_and_line(write_patch, capsys):
    path = write_patch("""
    hapticgraph: 1
    blocks:
      L: {type: lattice, shape: [5], mass: 0.001, tension: 1.0e9}
    connect: []
    """)
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{path}:3: block 'L' (lattice): unstable") and "Traceback" not in err
    bad = write_patch("hapticgraph: 1\nblocks:\n  L: {type: latice}\nconnect: []\n", name="bad.yaml")
    assert main(["modes", str(bad)]) == 2
    assert f"{bad}:3:" in capsys.readouterr().err
    assert main(["modes", str(STRING), "--count", "0"]) == 2
    assert "--count" in capsys.readouterr().err


def test_console_entry():
    r = subprocess.run([sys.executable, "-m", "hapticgraph", "modes", str(STRING), "--count", "1"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert "220.00" in r.stdout
