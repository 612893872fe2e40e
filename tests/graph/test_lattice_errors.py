"""Bad mass-spring input: every mistake is refused by `hapticgraph check` with exit status 2 and
`FILE:LINE: message` naming the block (and the cell) at fault, no traceback, nothing run."""
import re

import pytest

from hapticgraph.cli import main

HEAD = "hapticgraph: 1\nrate: 44100\nblocks:\n"

CASES = [
    # (id, blocks and connections, line, every substring the message at that line must hold)
    # -- shapes
    ("zero-extent", "  s: {type: lattice, shape: [10, 0]}\n", 4,
     ["block 's' (lattice)", "'shape'", "every extent must be at least 1", "[10, 0]"]),
    ("negative-extent", "  s:\n    type: lattice\n    mass: 0.001\n    shape: [-3]\n", 7,
     ["block 's' (lattice)", "'shape'", "at least 1", "[-3]"]),
    ("no-extent", "  s: {type: lattice, shape: []}\n", 4, ["block 's' (lattice)", "'shape'", "at least 1 item"]),
    ("too-many-cells", "  s: {type: lattice, shape: [100000, 100000, 10]}\n", 4,
     ["block 's' (lattice)", "'shape'", "100,000,000,000 cells", "GB", "at most 20,000,000 cells"]),
    # -- cell indices
    ("connection-index-out-of-range",
     "  s: {type: lattice, shape: [10]}\n  m: {type: mic}\nconnect:\n  - s[10].position -> m.in\n", 7,
     ["s[10]", "index [10] is out of range for shape [10]", "axis 0: 0 … 9"]),
    ("connection-index-2d-axis",
     "  s: {type: lattice, shape: [4, 6]}\n  n: {type: noise}\nconnect:\n  - n.out -> s[2, 6].force\n", 7,
     ["s[2, 6]", "out of range for shape [4, 6]", "axis 1: 0 … 5"]),
    ("connection-index-wrong-rank",
     "  s: {type: lattice, shape: [10, 4]}\n  m: {type: mic}\nconnect:\n  - s[3].position -> m.in\n", 7,
     ["s[3]", "1 coordinate(s)", "shape [10, 4]"]),
    ("connection-lattice-without-index",
     "  s: {type: lattice, shape: [10]}\n  m: {type: mic}\nconnect:\n  - s.position -> m.in\n", 7,
     ["'s' is a lattice", "s[i, ...].position"]),
    ("connection-index-on-single-cell",
     "  c: {type: cell}\n  m: {type: mic}\nconnect:\n  - c[2].position -> m.in\n", 7,
     ["block 'c' (cell)", "no cells to index with [2]"]),
    ("connection-unknown-cell-port",
     "  s: {type: lattice, shape: [10]}\n  m: {type: mic}\nconnect:\n  - s[2].pos -> m.in\n", 7,
     ["s[2]", "no port 'pos'", "force (input), position, velocity"]),
    ("lock-index-out-of-range", "  s:\n    type: lattice\n    shape: [10]\n    lock: [[12]]\n", 7,
     ["block 's' (lattice)", "'lock'", "index [12] is out of range"]),
    ("cut-index-out-of-range", "  s: {type: lattice, shape: [3, 3], cut: [[1, 3]]}\n", 4,
     ["block 's' (lattice)", "'cut'", "index [1, 3] is out of range"]),
    ("override-index-out-of-range", "  s: {type: lattice, shape: [10], cells: [{index: [10], mass: 0.002}]}\n", 4,
     ["block 's' (lattice)", "'cells'", "index [10] is out of range"]),
    # -- cut and locked cells have no ports
    ("cut-cell-wired",
     "  s:\n    type: lattice\n    shape: [6, 6]\n    cut: [[2, 2]]\n  m: {type: mic}\n"
     "connect:\n  - s[2, 2].velocity -> m.in\n", 10,
     ["s[2, 2]", "cut out of the lattice", "no ports"]),
    ("locked-cell-wired",
     "  s: {type: lattice, shape: [10], lock: [[3]]}\n  n: {type: noise}\nconnect:\n  - n.out -> s[3].force\n", 7,
     ["s[3]", "locked", "cannot be wired"]),
    ("locked-override-cell-wired",
     "  s: {type: lattice, shape: [10], cells: [{index: [4], locked: true}]}\n  m: {type: mic}\n"
     "connect:\n  - s[4].position -> m.in\n", 7,
     ["s[4]", "locked", "cannot be wired"]),
    # -- masses, tensions, damping
    ("lattice-mass-zero", "  s:\n    type: lattice\n    shape: [10]\n    mass: 0.0\n", 7,
     ["block 's' (lattice)", "'mass'", "must be greater than 0.0 kg"]),
    ("cell-mass-negative", "  c: {type: cell, mass: -0.001}\n", 4,
     ["block 'c' (cell)", "'mass'", "-0.001 must be greater than 0.0 kg"]),
    ("override-mass-zero",
     "  s:\n    type: lattice\n    shape: [10]\n    cells:\n      - {index: [2], mass: 0.002}\n"
     "      - {index: [3], mass: 0}\n", 9,
     ["block 's' (lattice)", "'cells'", "0 must be greater than 0"]),
    ("negative-tension", "  s:\n    type: lattice\n    shape: [4, 4]\n    tension: -1.0\n", 7,
     ["block 's' (lattice)", "'tension'", "-1.0 is below the minimum 0.0 N/m"]),
    ("negative-damping", "  s: {type: lattice, shape: [10], damping: -0.1}\n", 4,
     ["block 's' (lattice)", "'damping'", "-0.1 is below the minimum 0.0 N·s/m"]),
    ("negative-cell-damping", "  c: {type: cell, damping: -2}\n", 4,
     ["block 'c' (cell)", "'damping'", "below the minimum"]),
    ("negative-spring-tension",
     "  a: {type: cell}\n  b: {type: cell}\n  k:\n    type: spring\n    a: a\n    b: b\n    tension: -1\n", 10,
     ["block 'k' (spring)", "'tension'", "-1 is below the minimum 0.0 N/m"]),
    # -- springs
    ("spring-to-itself", "  s: {type: lattice, shape: [4, 4]}\n  k:\n    type: spring\n    a: \"s[1, 2]\"\n"
     "    b: \"s[1,2]\"\n", 5, ["block 'k' (spring)", "joins cell s[1, 2] to itself"]),
    ("spring-single-cell-to-itself", "  c: {type: cell}\n  k: {type: spring, a: c, b: c}\n", 5,
     ["block 'k' (spring)", "joins cell c to itself"]),
    ("spring-missing-block", "  s: {type: lattice, shape: [10]}\n  k:\n    type: spring\n    a: \"s[3]\"\n"
     "    b: \"q[1]\"\n", 8, ["block 'k' (spring)", "parameter 'b'", "no lattice or cell block named 'q'"]),
    ("spring-missing-cell", "  s: {type: lattice, shape: [10]}\n  k: {type: spring, a: \"s[3]\", b: \"s[10]\"}\n", 5,
     ["block 'k' (spring)", "parameter 'b'", "index [10] is out of range for shape [10]"]),
    ("spring-cut-cell", "  s: {type: lattice, shape: [10], cut: [[5]]}\n  k: {type: spring, a: \"s[3]\", b: \"s[5]\"}\n", 5,
     ["block 'k' (spring)", "parameter 'b'", "s[5] is cut out of its lattice"]),
    ("spring-lattice-without-index", "  s: {type: lattice, shape: [10]}\n  k: {type: spring, a: s, b: \"s[1]\"}\n", 5,
     ["block 'k' (spring)", "parameter 'a'", "'s' is a lattice", "s[i, ...]"]),
    ("spring-no-cell-named", "  s: {type: lattice, shape: [10]}\n  k: {type: spring, b: \"s[1]\"}\n", 5,
     ["block 'k' (spring)", "parameter 'a'", "write a cell as NAME or NAME[i, j]"]),
    ("spring-not-a-cell", "  s: {type: lattice, shape: [10]}\n  m: {type: mic}\n  k: {type: spring, a: m, b: \"s[1]\"}\n", 6,
     ["block 'k' (spring)", "parameter 'a'", "'m'"]),
    # -- the half-step scheme would blow up
    ("unstable", "  s: {type: lattice, shape: [10], mass: 0.000001, tension: 1000000.0}\n", 4,
     ["block 's' (lattice)", "unstable at 44100 Hz", "cell s[0]", "smallest stable mass"]),
]


@pytest.mark.parametrize("name,body,line,needles", CASES, ids=[c[0] for c in CASES])
def test_lattice_error(tmp_path, capsys, name, body, line, needles):
    path = tmp_path / f"{name}.yaml"
    path.write_text(HEAD + body, encoding="utf-8")
    assert main(["check", str(path)]) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert "Traceback" not in err and "ok:" not in captured.out
    lines = err.strip().splitlines()
    assert lines, "no message"
    assert all(re.match(rf"^{re.escape(str(path))}:\d+: \S", ln) for ln in lines), err
    at = [ln for ln in lines if ln.startswith(f"{path}:{line}: ")]
    assert at, f"nothing reported at line {line}:\n{err}"
    assert any(all(n in ln for n in needles) for ln in at), err


def test_every_lattice_problem_at_once(tmp_path, capsys):
    path = tmp_path / "many.yaml"
    path.write_text(HEAD + "  s: {type: lattice, shape: [10], lock: [[3]]}\n"
                           "  t: {type: lattice, shape: [0]}\n"
                           "  k: {type: spring, a: \"s[2]\", b: \"s[2]\"}\n"
                           "  n: {type: noise}\n"
                           "connect:\n  - n.out -> s[3].force\n  - n.out -> s[11].force\n", encoding="utf-8")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    for needle in ("every extent must be at least 1", "joins cell s[2] to itself", "s[3]: this cell is locked",
                   "s[11]: index [11] is out of range"):
        assert needle in err, err


def test_run_refuses_too(tmp_path, capsys):
    """`run` checks first: a bad lattice never starts (exit 2, no WAV written)."""
    path = tmp_path / "bad.yaml"
    path.write_text(HEAD + "  s: {type: lattice, shape: [10], mass: 0}\n", encoding="utf-8")
    out = tmp_path / "o.wav"
    assert main(["run", str(path), "--seconds", "0.01", "--out", str(out), "--quiet"]) == 2
    assert "'mass'" in capsys.readouterr().err
    assert not out.exists()
