"""docs/api.md is a test: its Python blocks, run in order in one namespace from the repository's
folder (they open patches/ by relative path), as a user pasting them would."""
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def test_every_python_block_of_api_md_runs(monkeypatch, capsys):
    blocks = FENCE.findall((ROOT / "docs" / "api.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 4
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": "api_doc"}
    for k, code in enumerate(blocks):
        exec(compile(code, f"docs/api.md block {k + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert "44100.0 2 ('str[20].position', 'pick.out')" in out
    assert "(10, 12) (10, 12)" in out
    assert "out of range for shape [10, 12]" in out
    assert namespace["s"].t > 0 and not namespace["s"].pending
