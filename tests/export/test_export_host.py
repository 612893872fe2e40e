"""examples/export_host: its Makefile exports patches/fig8_pluck_damp.yaml and builds host.c, a
C host that closes the haptic loop every sample with a simulated finger. Offline, the finger
plucks the string and then damps it as the patch says (≈ 13 dB/s before it rests, ≈ 260 dB/s
after), and the force stays within the host's own limit; under a dummy JACK server the host runs
for a second at the patch's rate without an xrun it causes."""
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from jack_server import jack_server, xruns
from project_env import ROOT

EXAMPLE = ROOT / "examples" / "export_host"
RATE = 19000                 # the patch's rate: the server runs at it
HOST_MAX_FORCE = 3.5         # host.c's own limit


def _built(tmp_path):
    folder = tmp_path / "export_host"
    shutil.copytree(EXAMPLE, folder)
    hapticgraph = Path(sys.executable).parent / "hapticgraph"
    proc = subprocess.run(["make", "-C", str(folder), f"HAPTICGRAPH={hapticgraph}",
                           f"PATCH={ROOT / 'patches' / 'fig8_pluck_damp.yaml'}"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (folder / "fig8.c").is_file() and (folder / "fig8.h").is_file()
    return folder / "host"


def _db(x):
    return 20.0 * np.log10(np.sqrt(np.mean(x ** 2)))


def test_the_host_plucks_then_damps_offline(tmp_path):
    host = _built(tmp_path)
    out = tmp_path / "out.f64"
    subprocess.run([str(host), "--offline", "1.2", str(out)], check=True, timeout=60)
    rows = np.fromfile(out).reshape(-1, 4)          # left, right, largest force so far, finger x
    assert len(rows) == round(1.2 * RATE)
    left = rows[:, 0]
    assert np.abs(left[: int(0.013 * RATE)]).max() == 0.0       # silent until the tip catches the string
    assert np.abs(left[: int(0.1 * RATE)]).max() > 0.1          # the pluck
    window = lambda s: left[int(s * RATE):int((s + 0.05) * RATE)]
    before = (_db(window(0.1)) - _db(window(0.7))) / 0.6        # dB/s, the string ringing freely
    after = (_db(window(0.85)) - _db(window(1.15))) / 0.3       # dB/s, the finger resting on it
    assert 8.0 < before < 20.0, before
    assert after > 150.0, after
    assert 0.5 < rows[-1, 2] <= HOST_MAX_FORCE                  # a force was felt, within the host's limit
    assert abs(rows[-1, 3]) < 0.002                             # the finger rests at the string


def test_the_host_runs_under_jack_without_an_xrun(tmp_path):
    host = _built(tmp_path)
    with jack_server(tmp_path, RATE, 128) as env:
        proc = subprocess.run([str(host), "--seconds", "1"], env=env, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    samples, _, _, rate = proc.stdout.split()[:4]
    assert float(rate) == RATE and int(samples) >= 0.8 * RATE, proc.stdout
    caused, _ = xruns((tmp_path / "jackd.log").read_text(errors="replace"), "fig8")
    assert caused == 0
