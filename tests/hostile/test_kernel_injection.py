"""Issue 10.1: the generated kernel holds no text from the patch. A file, patch, block or device
name that is Python code stays inert: no file is created, check and run still work."""
import re

from hostile_env import run_hg

EVIL = "import os; os.system('touch PWNED')"

PATCH = """hapticgraph: 1
name: "x\\n%s\\n#"
devices:
  "finger\\n": {driver: simulated, script: [{t: 0.0, x: 0.0}]}
blocks:
  "lonely\\n": {type: gain, gain: 0.5}
  pick: {type: pluck, time: 0.0, force: 1.0, duration: 0.0005}
  loop: {type: delay, length: 99}
  mic:  {type: mic, gain: 0.5}
  out:  {type: audio_out, channels: 2}
connect:
  - pick.out -> loop.in
  - loop.out -> mic.in
  - mic.left -> out.left
  - mic.right -> out.right
""" % EVIL


def test_code_in_a_patch_file_name_never_runs(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    # a newline, code, then `#` so the rest of a pasted comment line would be commented out
    name = f"x\n{EVIL}\n#.yaml"
    # names the schema accepts (a newline in a block or device name is refused: the next test)
    clean = PATCH.replace('name: "x\\n%s\\n#"\n' % EVIL, "").replace('"finger\\n"', "finger")
    (work / name).write_text(clean.replace('"lonely\\n"', "lonely"))
    env = {"HAPTICGRAPH_CACHE": str(tmp_path / "cache")}
    check = run_hg("check", name, cwd=work, env=env)
    assert check.returncode == 0, check.stderr
    run = run_hg("run", name, "--seconds", "0.01", "--out", "o.wav", "--quiet", cwd=work, env=env)
    assert run.returncode == 0, run.stderr
    assert (work / "o.wav").is_file()
    assert not (work / "PWNED").exists() and not (tmp_path / "PWNED").exists()
    sources = list((tmp_path / "cache").glob("kernel_*/kernel.py"))
    assert sources
    for src in sources:
        text = src.read_text()
        assert "os.system" not in text and "'touch" not in text


def test_code_in_patch_block_and_device_names_never_runs(tmp_path):
    (tmp_path / "p.yaml").write_text(PATCH)
    env = {"HAPTICGRAPH_CACHE": str(tmp_path / "cache")}
    check = run_hg("check", "p.yaml", cwd=tmp_path, env=env)
    run = run_hg("run", "p.yaml", "--seconds", "0.01", "--out", "o.wav", "--quiet", "--probe", "lonely\n.out",
                 cwd=tmp_path, env=env)
    assert not (tmp_path / "PWNED").exists()
    # the schema may refuse the trailing newline of a name (exit 2) or accept it; never code, never a crash
    for proc in (check, run):
        assert proc.returncode in (0, 2), proc.stderr
        assert "Traceback" not in proc.stderr
    for src in (tmp_path / "cache").glob("kernel_*/kernel.py"):
        text = src.read_text()
        assert "os.system" not in text
        # every comment is reduced to [A-Za-z0-9_] words
        for comment in re.findall(r"#(.*)$", text, flags=re.M):
            assert "'" not in comment and '"' not in comment and "\\" not in comment
