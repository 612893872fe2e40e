"""Issue 10.8 and 11.2: plugins are the only code a patch runs, and the user is told. A plugin
that exits or raises at import, or whose body numba cannot compile, fails `check` naming the
plugin's file and line (exit 2, no traceback); `run` says the same in one short message."""
from hostile_env import assert_patch_error, run_hg

STRING = """hapticgraph: 1
plugins: [{plugin}]
blocks:
  pick: {{type: pluck, time: 0.0, force: 1.0, duration: 0.0005}}
  loop: {{type: delay, length: 99}}
  shape: {{type: {kind}}}
  mic:  {{type: mic, gain: 0.5}}
  out:  {{type: audio_out, channels: 2}}
connect:
  - pick.out -> loop.in
  - loop.out -> shape.in
  - shape.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
"""

UNCOMPILABLE = '''from hapticgraph.blocks import Block, In, Out, Param


class Bad(Block, name="bad"):
    """out = in + a dictionary (numba cannot add those)."""
    x = In(name="in")
    y = Out(name="out")
    amount = Param(0.3)

    @staticmethod
    def output(x, amount):
        table = {"a": 1.0}
        return x + table
'''


def _env(tmp_path):
    return {"HAPTICGRAPH_CACHE": str(tmp_path / "cache")}


def test_uncompilable_plugin_fails_check_at_its_line(tmp_path):
    (tmp_path / "bad.py").write_text(UNCOMPILABLE)
    (tmp_path / "p.yaml").write_text(STRING.format(plugin="bad.py", kind="bad"))
    check = run_hg("check", "p.yaml", cwd=tmp_path, env=_env(tmp_path))
    assert_patch_error(check, "bad.py:13: block 'shape' (bad): numba cannot compile output(): ")
    problems = [ln for ln in check.stderr.splitlines() if not ln.startswith("hapticgraph: compiling")]
    assert len(problems) == 1 and len(problems[0]) < 400, check.stderr
    run = run_hg("run", "p.yaml", "--seconds", "0.01", "--out", "o.wav", cwd=tmp_path, env=_env(tmp_path))
    assert_patch_error(run, "bad.py:13: block 'shape' (bad): numba cannot compile output(): ")
    assert "mic" not in run.stderr and "During:" not in run.stderr and len(run.stderr) < 1000, run.stderr
    assert not (tmp_path / "o.wav").exists()
    # a failed compile leaves no half-built entry behind
    assert not [p.name for p in (tmp_path / "cache").iterdir() if p.name.startswith(".kernel_")]


def test_check_lists_the_plugin_files_it_runs(tmp_path):
    (tmp_path / "good.py").write_text(UNCOMPILABLE.replace("return x + table", "return x * amount"))
    (tmp_path / "p.yaml").write_text(STRING.format(plugin="good.py", kind="bad"))
    check = run_hg("check", "p.yaml", cwd=tmp_path, env=_env(tmp_path))
    assert check.returncode == 0, check.stderr
    assert f"plugins run: good.py ({(tmp_path / 'good.py').resolve()})" in check.stdout


def test_plugin_calling_sys_exit_or_raising_at_import_is_an_error(tmp_path):
    (tmp_path / "p.yaml").write_text(STRING.format(plugin="quit.py", kind="gain"))
    for body, fragment in (("import sys\nsys.exit(0)\n", "quit.py:2): it called sys.exit(0)"),
                           ("import sys\nsys.exit()\n", "it called sys.exit(None)"),
                           ("raise SystemExit('bye')\n", "it called sys.exit('bye')"),
                           ("import os\nraise KeyError('k')\n", "quit.py:2): KeyError: 'k'")):
        (tmp_path / "quit.py").write_text(body)
        for command in (("check", "p.yaml"), ("run", "p.yaml", "--seconds", "0.01", "--out", "o.wav")):
            proc = run_hg(*command, cwd=tmp_path, env=_env(tmp_path))
            assert_patch_error(proc, "p.yaml:2: plugin file 'quit.py' failed to import (")
            assert fragment in proc.stderr, proc.stderr


def test_module_plugin_calling_sys_exit_is_an_error(tmp_path):
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "leaver.py").write_text("import sys\n\nsys.exit(3)\n")
    (tmp_path / "p.yaml").write_text(STRING.format(plugin="leaver", kind="gain"))
    proc = run_hg("check", "p.yaml", cwd=tmp_path, env={**_env(tmp_path), "PYTHONPATH": str(tmp_path / "site")})
    assert_patch_error(proc, "p.yaml:2: plugin module 'leaver' failed to import (leaver.py:3): it called sys.exit(3)")


def test_wrong_number_of_outputs_or_states_is_refused_at_declaration(tmp_path):
    head = "from hapticgraph.blocks import Block, In, Out, State\n\n\nclass Split(Block, name='split'):\n" \
           "    '''a = in, b = -in.'''\n    x = In(name='in')\n    a = Out()\n    b = Out()\n"
    cases = {
        "one value": "    @staticmethod\n    def output(x):\n        return x\n",
        "three": "    @staticmethod\n    def output(x):\n        return x, -x, 0.0\n",
        "state": "    s = State()\n\n    @staticmethod\n    def output(s):\n        return s, -s\n\n"
                 "    @staticmethod\n    def update(x, s):\n        return x, s\n",
    }
    (tmp_path / "p.yaml").write_text("hapticgraph: 1\nplugins: [split.py]\nblocks:\n  s: {type: split}\n")
    expected = {"one value": "output() returns one value (line 12) but the block declares 2 outputs",
                "three": "output() returns 3 values (line 12) but the block declares 2 outputs",
                "state": "update() returns 2 values (line 18) but the block declares 1 state"}
    for case, body in cases.items():
        (tmp_path / "split.py").write_text(head + "\n" + body)
        proc = run_hg("check", "p.yaml", cwd=tmp_path, env=_env(tmp_path))
        assert_patch_error(proc, "block type Split ('split'): " + expected[case])
