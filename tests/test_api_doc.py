"""docs/api.md is a test: its Python blocks, run in order in one namespace, as a user pasting them
would, from a folder holding the repository's patches/ and the files the pages save (bad.yaml),
and what its comments claim is checked."""
import re

from test_docs_pages import ROOT, make_workdir

FENCE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def test_every_python_block_of_api_md_runs(monkeypatch, capsys, tmp_path):
    blocks = FENCE.findall((ROOT / "docs" / "api.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 5
    monkeypatch.chdir(make_workdir(tmp_path))
    namespace = {"__name__": "api_doc"}
    for k, code in enumerate(blocks):
        exec(compile(code, f"docs/api.md block {k + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    lines = out.splitlines()
    # Load, check, render
    assert lines[0] == "[]" and lines[1] == "44100.0 (44100, 2) (44100,)", out
    assert lines[2].startswith("4 ") and "dealy" in lines[2]                # bad.yaml's problems
    assert "probe 'loop.nope'" in out
    # A running patch
    assert "44100.0 2 ('str[20].position', 'pick.out')" in out
    assert "(10, 12) (10, 12)" in out
    assert "out of range for shape [10, 12]" in out
    assert namespace["s"].t > 0 and not namespace["s"].pending
