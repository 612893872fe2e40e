"""Bad mass-spring input: every mistake is refused by `hapticgraph check` with exit status 2 and
`FILE:LINE: message` naming the block (and the cell) at fault, no traceback, nothing run."""


from hapticgraph.cli import main

HEAD = "hapticgraph: 1\nrate: 44100\nblocks:\n"

# Each single mistake is a patch in tests/corpus/ (tests/test_corpus.py); here: several at once.


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
