"""Schema verdicts (graph/verdicts.py): a patch found clean is not checked again, so loading it a
second time imports no jsonschema; the remembered verdict makes the same ints the check made; a
patch with a problem, an edited patch and a damaged verdict are checked every time."""
import json
import os
import subprocess
import sys

import pytest

from project_env import ROOT
from hapticgraph.graph import validate
from hapticgraph.graph.errors import PatchError
from hapticgraph.graph.patch import load

PATCH = """\
hapticgraph: 1
rate: 44100
blocks:
  hiss: {type: noise, amplitude: 0.1, seed: 7.0}
  out: {type: audio_out, channels: 1.0}
connect:
  - hiss.out -> out.ch0
"""

PROBE = """
import sys
from hapticgraph.graph.patch import load
patch = load(sys.argv[1])
print(sorted((n, repr(b.values)) for n, b in patch.blocks.items()))
print("jsonschema" in sys.modules)
"""


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _verdicts(cache):
    return sorted((cache / "verdicts").glob("*.json")) if (cache / "verdicts").is_dir() else []


def _unchecked(monkeypatch):
    """The schema check itself made to fail: a load that passes used a verdict."""
    def refuse(*args, **kwargs):
        raise AssertionError("checked again")
    monkeypatch.setattr(validate, "whole_errors", refuse)


def test_a_second_load_imports_no_jsonschema(tmp_path):
    (tmp_path / "p.yaml").write_text(PATCH)
    env = {**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / "cache")}

    def probe():
        proc = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path / "p.yaml")], capture_output=True,
                              text=True, env=env, cwd=ROOT, timeout=120)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout.splitlines()
    first, second = probe(), probe()
    assert first[1] == "True" and second[1] == "False"
    assert first[0] == second[0]


def test_the_verdict_makes_the_same_ints(tmp_path, cache, monkeypatch):
    (tmp_path / "p.yaml").write_text(PATCH)
    checked = load(tmp_path / "p.yaml")
    assert len(_verdicts(cache)) == 1
    paths = json.loads(_verdicts(cache)[0].read_text())["whole"]
    assert sorted(paths) == [["blocks", "hiss", "seed"], ["blocks", "out", "channels"]]
    _unchecked(monkeypatch)
    recalled = load(tmp_path / "p.yaml")
    for name in ("hiss", "out"):
        assert checked.blocks[name].values == recalled.blocks[name].values
    assert type(recalled.blocks["hiss"].values["seed"]) is int and recalled.doc["blocks"]["out"]["channels"] == 1
    assert type(recalled.doc["blocks"]["out"]["channels"]) is int


def test_a_patch_with_a_problem_is_checked_every_time(tmp_path, cache):
    (tmp_path / "p.yaml").write_text(PATCH.replace("seed: 7.0", "seed: 7.5"))
    messages = []
    for _ in range(2):
        with pytest.raises(PatchError) as err:
            load(tmp_path / "p.yaml")
        messages.append([str(p) for p in err.value.problems])
    assert messages[0] == messages[1] and "7.5 is not an integer" in messages[0][0]
    assert _verdicts(cache) == []


def test_an_edited_patch_is_checked_again(tmp_path, cache, monkeypatch):
    (tmp_path / "p.yaml").write_text(PATCH)
    load(tmp_path / "p.yaml")
    _unchecked(monkeypatch)
    load(tmp_path / "p.yaml")                                         # remembered
    load(tmp_path / "p.yaml", overrides=["hiss.amplitude=0.1"])       # the same document
    with pytest.raises(AssertionError, match="checked again"):      # --set makes another one
        load(tmp_path / "p.yaml", overrides=["hiss.amplitude=0.3"])
    (tmp_path / "p.yaml").write_text(PATCH.replace("amplitude: 0.1", "amplitude: 0.2"))
    with pytest.raises(AssertionError, match="checked again"):
        load(tmp_path / "p.yaml")


@pytest.mark.parametrize("damage", ["garbage", "other key", "other paths"])
def test_a_damaged_verdict_is_not_used(tmp_path, cache, monkeypatch, damage):
    (tmp_path / "p.yaml").write_text(PATCH)
    load(tmp_path / "p.yaml")
    verdict = _verdicts(cache)[0]
    content = json.loads(verdict.read_text())
    if damage == "garbage":
        verdict.write_bytes(b"\x00{not json")
    elif damage == "other key":
        verdict.write_text(json.dumps({**content, "key": "0" * 32}))
    else:       # a path that does not lead to a whole float: nothing is made an int
        verdict.write_text(json.dumps({**content, "whole": content["whole"] + [["blocks", "hiss", "amplitude"]]}))
    _unchecked(monkeypatch)
    with pytest.raises(AssertionError, match="checked again"):
        load(tmp_path / "p.yaml")
