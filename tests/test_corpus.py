"""The bad-input corpus (tests/corpus/): one patch for every kind of error the loader, the graph
checks, the stability check and the devices can raise. Each exits 2 with `FILE:LINE: message`
naming the thing at fault, no traceback, within 2 s of CPU time (a bound that catches an expanded
alias bomb or a quadratic check, hours of work, and not the load of other processes: wall time
on a busy machine once took 2.5 s for 0.05 s of work); `check` reports all problems at once."""
import re
import time
from pathlib import Path

import pytest
import yaml

from hapticgraph.cli import main

# not `from conftest import ROOT`: tests/hostile has a conftest.py too, and the module name clashes
CORPUS = Path(__file__).resolve().parent / "corpus"
EXPECTED = yaml.safe_load((CORPUS / "expected.yaml").read_text(encoding="utf-8"))


def test_every_corpus_file_has_an_expectation_and_back():
    files = {p.stem for p in CORPUS.glob("*.yaml")} - {"expected"}
    assert files == set(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_corpus_patch(name, capsys):
    path = CORPUS / f"{name}.yaml"
    start = time.process_time()
    status = main(["check", str(path)])
    seconds = time.process_time() - start
    err = capsys.readouterr().err
    assert status == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert lines and all(re.match(rf"^{re.escape(str(path))}:\d+: \S", ln) for ln in lines), err
    want = EXPECTED[name]
    at_line = [ln for ln in lines if ln.startswith(f"{path}:{want['line']}: ")]
    assert any(all(m in ln for m in want["messages"]) for ln in at_line), err
    assert seconds < 2.0, f"{name} took {seconds:.2f} s of CPU time"
