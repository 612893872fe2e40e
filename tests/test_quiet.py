"""Issue 33 item 2: `hapticgraph run --quiet` (or `-q`) prints nothing on success — no summary, no
progress bar, no "compiling kernel…" notice — while errors still go to stderr."""
import os
import subprocess
import sys

import pytest
import soundfile

from project_env import ROOT

KARPLUS = ROOT / "patches" / "karplus_strong.yaml"


def _hg(args, cache):
    env = dict(os.environ, HAPTICGRAPH_CACHE=str(cache))
    env.pop("HAPTICGRAPH_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "hapticgraph", *map(str, args)], env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("flag", ["-q", "--quiet"])
def test_a_quiet_run_prints_nothing_even_when_it_compiles(tmp_path, flag):
    out = tmp_path / "w.wav"
    proc = _hg(["run", KARPLUS, "--seconds", 0.5, "--out", out, flag], tmp_path / f"empty{flag}")   # a cold cache
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, "", "")
    assert soundfile.info(out).frames == 22050


def test_without_quiet_the_run_says_what_it_wrote(tmp_path):
    out = tmp_path / "w.wav"
    proc = _hg(["run", KARPLUS, "--seconds", 0.5, "--out", out], tmp_path / "kernels")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"{KARPLUS}: 0.5 s at 44100 Hz (compiled; compile ") and f"-> {out}" in proc.stdout


def test_a_quiet_run_still_reports_errors(tmp_path):
    proc = _hg(["run", KARPLUS, "--seconds", 0.5, "--out", tmp_path / "no" / "w.wav", "-q"], tmp_path / "kernels")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("hapticgraph: error: --out") and "does not exist" in proc.stderr
