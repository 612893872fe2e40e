"""`hapticgraph fit` recovers the loop length and the damping of a Karplus-Strong string from its
own render (issue 23, item 7): short renders, a small population, a fixed seed."""
import pathlib
import shutil

import numpy as np
import pytest
import soundfile

import hapticgraph
from hapticgraph.sweeps import fitting

ROOT = pathlib.Path(__file__).resolve().parents[2]
LENGTH, GAIN = 121.0, 0.985


def test_spectral_distance_is_zero_for_the_same_signal_and_grows_with_detuning():
    t = np.arange(11025) / 44100
    x = np.sin(2 * np.pi * 440 * t) * np.exp(-3 * t)
    near = np.sin(2 * np.pi * 445 * t) * np.exp(-3 * t)
    far = np.sin(2 * np.pi * 520 * t) * np.exp(-3 * t)
    assert fitting.spectral_distance(x, x) == pytest.approx(0.0, abs=1e-9)
    assert 0 < fitting.spectral_distance(near, x) < fitting.spectral_distance(far, x)


def test_fit_recovers_loop_length_and_damping_within_one_percent(tmp_path, dask_client):
    patch = tmp_path / "ks.yaml"
    shutil.copy(ROOT / "patches" / "karplus_strong.yaml", patch)
    take = hapticgraph.render(hapticgraph.load(patch, overrides=[f"loop.length={LENGTH}", f"damp.gain={GAIN}"]),
                              seconds=0.2)
    soundfile.write(tmp_path / "take.wav", take.audio.astype(np.float32), 44100, subtype="FLOAT")
    axes = tmp_path / "axes.yaml"
    axes.write_text("loop.length: {min: 90, max: 150, step: 1}\ndamp.gain: {min: 0.95, max: 0.999}\n")
    result = hapticgraph.fit(patch, tmp_path / "take.wav", axes, client=dask_client, seed=3, popsize=6,
                             maxiter=20, out=tmp_path / "best.yaml", results=tmp_path / "fit", report=lambda text: None)
    assert result.values["loop.length"] == pytest.approx(LENGTH, rel=0.01)
    assert result.values["damp.gain"] == pytest.approx(GAIN, rel=0.01)
    assert 1 - result.values["damp.gain"] == pytest.approx(1 - GAIN, rel=0.2)     # the loss per pass too
    best = hapticgraph.load(tmp_path / "best.yaml")
    assert best.blocks["loop"].values["length"] == result.values["loop.length"]
    assert best.blocks["damp"].values["gain"] == result.values["damp.gain"]
    text = (tmp_path / "best.yaml").read_text()
    assert "# Karplus-Strong plucked string." in text          # the patch's text, values changed
    rows = (tmp_path / "fit" / "manifest.csv").read_text().splitlines()
    assert len(rows) - 1 == result.evaluations > 16
    assert rows[0].split(",")[:5] == ["id", "status", "error", "loop.length", "damp.gain"]


def test_fit_axes_are_checked_at_the_axes_file_lines(tmp_path):
    patch = tmp_path / "ks.yaml"
    shutil.copy(ROOT / "patches" / "karplus_strong.yaml", patch)
    axes = tmp_path / "axes.yaml"
    axes.write_text("loop.length: {min: -4, max: 150}\ndamp.gian: {min: 0.9, max: 0.99}\n")
    soundfile.write(tmp_path / "take.wav", np.zeros(1000, dtype=np.float32), 44100)
    with pytest.raises(hapticgraph.PatchError) as err:
        hapticgraph.fit(patch, tmp_path / "take.wav", axes)
    text = str(err.value)
    assert f"{axes}:2: axes: damp.gian" in text and "did you mean 'gain'" in text


def test_fit_command_line_writes_the_best_patch_and_a_bad_axes_file_exits_2(tmp_path):
    import subprocess
    import sys
    patch = tmp_path / "ks.yaml"
    shutil.copy(ROOT / "patches" / "karplus_strong.yaml", patch)
    soundfile.write(tmp_path / "take.wav", hapticgraph.render(hapticgraph.load(patch), seconds=0.1).audio, 44100)
    (tmp_path / "bad.yaml").write_text("mic.pan: {min: 0.0, max: 3.0}\n")
    args = [sys.executable, "-m", "hapticgraph", "fit", str(patch), "--target", str(tmp_path / "take.wav")]
    bad = subprocess.run(args + ["--axes", str(tmp_path / "bad.yaml")], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and bad.stderr.startswith(f"{tmp_path / 'bad.yaml'}:1: mic.pan=3.0:"), bad.stderr
    (tmp_path / "axes.yaml").write_text("damp.gain: {min: 0.99, max: 0.999}\n")
    done = subprocess.run(args + ["--axes", str(tmp_path / "axes.yaml"), "--workers", "1", "--popsize", "2",
                                  "--maxiter", "1"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("damp.gain=0.99") and "best patch -> " in done.stdout
    fitted = hapticgraph.load(tmp_path / "ks_fit.yaml")
    assert 0.99 <= fitted.blocks["damp"].values["gain"] <= 0.999
    assert (tmp_path / "ks_fit" / "manifest.csv").exists()
