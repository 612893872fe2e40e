"""The built wheel installs in a fresh environment and every subpackage imports from outside the
repository; the example plugin package installs beside it and registers by entry point."""
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv

import pytest

from project_env import ROOT


def _run(cmd, **kw):
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)
    assert proc.returncode == 0, f"{cmd}\n{proc.stdout}\n{proc.stderr}"
    return proc


@pytest.fixture(scope="module")
def fresh_env(tmp_path_factory):
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "wheels"
    # built from a copy: setuptools builds in the source tree (build/, *.egg-info), and nothing is
    # written into the repository (nor read from what an earlier build left there)
    source = base / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "*.egg-info", "__pycache__", ".hypothesis", ".pytest_cache", ".import_linter_cache"))
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(wheels),
          str(source), str(source / "examples" / "hapticgraph-example-plugin")])
    env_dir = base / "env"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = env_dir / ("Scripts" if os.name == "nt" else "bin") / "python"
    # dependencies (numpy, numba, ...) come from this interpreter's site-packages as a plain path
    # entry: its .pth hooks (e.g. an editable install of hapticgraph) are NOT run in the new env
    site = _run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    # (and those of a venv made with --system-site-packages: its base's site-packages)
    outer = [sysconfig.get_paths()["purelib"]] + [p for p in sys.path if p.endswith("site-packages")]
    with open(os.path.join(site, "outer_deps.pth"), "w") as f:
        f.write("\n".join(dict.fromkeys(outer)) + "\n")
    _run([str(py), "-m", "pip", "install", "-q", "--no-deps", "--no-index", *map(str, wheels.glob("*.whl"))])
    return py, base


def test_wheel_imports_every_subpackage(fresh_env):
    py, base = fresh_env
    code = ("import hapticgraph, hapticgraph.blocks, hapticgraph.graph, hapticgraph.devices, hapticgraph.cli, "
            "hapticgraph.graph.kernel, hapticgraph.devices.wav, os; "
            "print(os.path.dirname(hapticgraph.__file__)); print(os.path.dirname(hapticgraph.blocks.__file__))")
    out = _run([str(py), "-c", code], cwd=str(base)).stdout.split()
    for folder in out:
        assert folder.startswith(str(base)), folder   # installed copy, not the repository
        assert not folder.startswith(str(ROOT))


def test_wheel_cli_runs_a_patch_and_finds_entry_point_plugin(fresh_env, tmp_path):
    py, base = fresh_env
    env = {**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / "cache")}
    rows = json.loads(_run([str(py), "-m", "hapticgraph", "blocks", "--json"], cwd=str(tmp_path), env=env).stdout)
    types = {r["type"]: r for r in rows}
    assert types["soft_clip"]["origin"].startswith("entry point example")
    patch = tmp_path / "clip.yaml"
    patch.write_text("hapticgraph: 1\nblocks:\n  w: {type: wavetable, amplitude: 4.0}\n"
                     "  c: {type: soft_clip, limit: 0.5}\n  out: {type: audio_out, channels: 1}\n"
                     "connect: [w.out -> c.in, c.out -> out.ch0]\n")
    _run([str(py), "-m", "hapticgraph", "run", str(patch), "--seconds", "0.1", "--out", str(tmp_path / "c.wav")],
         cwd=str(tmp_path), env=env)
    assert (tmp_path / "c.wav").stat().st_size > 4 * 4410
