"""examples/driver_plugin is a real extension point: `pip install examples/driver_plugin` into a
fresh virtual environment adds `driver: sine` to the one table of drivers, and its patch runs
there (the hand moves as its settings say, the string sounds, the force comes back to the hand);
the loader checks its entries, `--device` chooses it."""
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import venv

import pytest

from conftest import ROOT

PLUGIN = ROOT / "examples" / "driver_plugin"


def _run(cmd, **kw):
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)
    return proc


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    """A venv (--system-site-packages) that sees this hapticgraph and has the plugin installed."""
    base = tmp_path_factory.mktemp("driver_plugin")
    env_dir = base / "env"
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    py = env_dir / ("Scripts" if os.name == "nt" else "bin") / "python"
    site = _run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    # this interpreter's packages (hapticgraph itself, maybe an editable install) as a site folder
    with open(os.path.join(site, "outer_site.pth"), "w") as f:
        f.write(f"import site; site.addsitedir({sysconfig.get_paths()['purelib']!r})\n")
    source = base / "driver_plugin"              # built from a copy: nothing is written into the repository
    shutil.copytree(PLUGIN, source)
    proc = _run([str(py), "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--no-index", str(source)])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return py, base


def test_the_installed_plugin_adds_its_driver_and_its_patch_runs(plugin_env, tmp_path):
    py, base = plugin_env
    env = {**os.environ, "HAPTICGRAPH_CACHE": str(tmp_path / "cache")}
    code = textwrap.dedent(f"""
        import math
        import numpy as np
        import hapticgraph
        from hapticgraph.devices import driver_kinds
        from hapticgraph.devices.table import driver_origins
        assert type(driver_kinds()["sine"]).__module__ == "hg_sine_hand.kind", driver_kinds()
        print("origin:", driver_origins()["sine"])
        path = {str(PLUGIN / "sine_hand.yaml")!r}
        with hapticgraph.Session.open(path, probes=["hand.x", "touch.reaction"], blocksize=256) as s:
            block = np.concatenate([s.process(256).copy() for _ in range(40)])
            hand = s.drivers["hand"]
        t = np.arange(len(block)) / 44100.0
        assert np.allclose(s.probes_of(block)["hand.x"], 0.004 * np.sin(2 * math.pi * 3.0 * t), rtol=0, atol=1e-12)
        assert np.max(np.abs(s.audio_of(block))) > 1e-4                      # the string sounds
        felt = np.max(np.abs(s.probes_of(block)["touch.reaction"]))
        assert 0 < hand.peak <= 2.0 and math.isclose(hand.peak, min(felt, 2.0))
        with hapticgraph.Session.open(path, probes=["hand.x"], devices={{"hand": "sine,frequency=5"}}) as s:
            x = s.process(64)[:, 1].copy()
        assert np.allclose(x, 0.004 * np.sin(2 * math.pi * 5.0 * np.arange(64) / 44100.0), rtol=0, atol=1e-12)
        print("ok")
    """)
    proc = _run([str(py), "-c", code], cwd=str(tmp_path), env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "origin: hapticgraph-sine-hand (hg_sine_hand.kind:SineKind)" in proc.stdout and "ok" in proc.stdout
    out = tmp_path / "sine.wav"
    proc = _run([str(py), "-m", "hapticgraph", "run", str(PLUGIN / "sine_hand.yaml"), "--seconds", "0.2",
                 "--out", str(out), "--quiet"], cwd=str(tmp_path), env=env)
    assert proc.returncode == 0, proc.stderr
    assert out.stat().st_size > 4 * 8820


def test_the_loader_checks_the_plugins_entries(plugin_env, tmp_path):
    py, _ = plugin_env
    bad = tmp_path / "bad.yaml"
    bad.write_text((PLUGIN / "sine_hand.yaml").read_text().replace(
        "{driver: sine, frequency: 3.0, amplitude: 0.004, max_force: 2.0}",
        "{driver: sine, frequency: 3000.0, amplitude: 0.004, wobble: 1}"))
    proc = _run([str(py), "-m", "hapticgraph", "check", str(bad)], cwd=str(tmp_path))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = next(i for i, text in enumerate(bad.read_text().splitlines(), 1) if "driver: sine" in text)
    assert f"{bad}:{line}: device 'hand'" in proc.stderr
    assert "wobble" in proc.stderr and "75.4 m/s" in proc.stderr


def test_without_the_plugin_the_driver_is_unknown(tmp_path):
    """In this environment (no plugin installed) `driver: sine` is an unknown driver."""
    proc = _run([sys.executable, "-m", "hapticgraph", "check", str(PLUGIN / "sine_hand.yaml")], cwd=str(tmp_path))
    assert proc.returncode == 2 and "unknown driver 'sine'" in proc.stderr
