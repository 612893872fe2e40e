"""Fast start: `hapticgraph --help`, `check`, `graph` (and `import hapticgraph`) import neither numba,
scipy nor sounddevice; they are imported when a kernel is compiled, a mode solved or a card opened.
Each case runs in a fresh interpreter; the time it takes is measured in the report, never asserted."""
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too

HEAVY = ("numba", "scipy", "sounddevice")

# run `hapticgraph ARGS` in this interpreter, then print which heavy modules were imported
PROBE = """
import sys
from hapticgraph.cli import main
try:
    status = main({args!r})
except SystemExit as exc:          # --help exits from argparse
    status = exc.code
print("STATUS", status)
print("HEAVY", ",".join(m for m in {heavy!r} if m in sys.modules))
"""


def _heavy_after(code, cwd, env=None):
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=cwd,
                          env=env)
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = dict(line.split(" ", 1) if " " in line else (line, "") for line in proc.stdout.splitlines()
                 if line.startswith(("STATUS", "HEAVY")))
    return lines.get("STATUS"), [m for m in lines.get("HEAVY", "").split(",") if m]


@pytest.mark.parametrize("args", [
    ["--help"],
    ["check", "patches/karplus_strong.yaml"],
    ["check", "patches/fig8_pluck_damp.yaml"],            # devices (a simulated finger) and couplings
    ["check", "patches/babe_is_sleeping.yaml"],           # lattices and springs
    ["graph", "examples/file_plugin/saturated_string.yaml"],   # a plugin file with @helper functions
    ["graph", "patches/fig8_pluck_damp.yaml", "--format", "mermaid"],
    ["graph", "patches/babe_is_sleeping.yaml"],
], ids=lambda a: " ".join(a))
def test_command_imports_no_heavy_module(args):
    status, heavy = _heavy_after(PROBE.format(args=args, heavy=HEAVY), cwd=ROOT)
    assert status == "0"
    assert heavy == [], f"hapticgraph {' '.join(args)} imported {heavy}"


def test_check_of_a_plugin_patch_compiles_the_plugin_and_nothing_more():
    # check compiles every plugin block (so a broken plugin fails check): numba (which brings scipy
    # along), never the sound card's library
    status, heavy = _heavy_after(PROBE.format(args=["check", "examples/file_plugin/saturated_string.yaml"],
                                              heavy=HEAVY), cwd=ROOT)
    assert status == "0"
    assert "numba" in heavy and "sounddevice" not in heavy


def test_import_hapticgraph_and_its_api_names_is_light():
    code = ("import sys, hapticgraph\n"
            "from hapticgraph import load, check, PatchError, Problem\n"
            "problems = check('patches/karplus_strong.yaml')\n"
            "print('STATUS', len(problems))\n"
            f"print('HEAVY', ','.join(m for m in {HEAVY!r} if m in sys.modules))\n")
    status, heavy = _heavy_after(code, cwd=ROOT)
    assert status == "0" and heavy == []


def test_the_heavy_modules_do_come_when_a_kernel_is_compiled(tmp_path):
    """The probe can see numba: compiling a kernel (an empty kernel cache) imports it. (Loading
    one built ahead of time does not: tests/graph/test_aot.py.)"""
    code = ("import sys, hapticgraph\n"
            "r = hapticgraph.render('patches/karplus_strong.yaml', seconds=0.01)\n"
            "print('STATUS', r.audio.shape[0])\n"
            f"print('HEAVY', ','.join(m for m in {HEAVY!r} if m in sys.modules))\n")
    import os
    status, heavy = _heavy_after(code, cwd=ROOT, env={**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / "cache")})
    assert status == "441" and "numba" in heavy
