"""`hapticgraph export --to lv2`: a bundle Debian's lilv tools load (lv2info lists it) and run
(lv2apply over a WAV file gives hapticgraph's samples). LV2 carries 32-bit floats: the plugin
computes in double from the file's float samples, as Python does, so its output is Python's
render rounded once to float32 — equal as float32, within half a float32 ulp (2**-24 relative)."""
import os
import shutil
import subprocess

import numpy as np
import pytest
import soundfile

import hapticgraph
from hapticgraph.cli.main import main
from project_env import ROOT

PATCH = ROOT / "tests" / "export" / "data" / "ks_in.yaml"
URI = "urn:hapticgraph:ks_in"


@pytest.fixture
def bundle(tmp_path):
    """The test patch beside an input WAV (a noise burst, then silence), exported as an LV2 bundle."""
    patch = tmp_path / "ks_in.yaml"
    shutil.copy(PATCH, patch)
    burst = np.zeros(22050, dtype=np.float32)
    burst[1000:1400] = np.random.default_rng(1).uniform(-0.5, 0.5, 400).astype(np.float32)
    soundfile.write(tmp_path / "input.wav", burst, 44100, subtype="FLOAT")
    assert main(["export", str(patch), "--to", "lv2", "--out", str(tmp_path / "lv2")]) == 0
    return tmp_path


def _lilv(tool, folder, *args):
    env = dict(os.environ, LV2_PATH=str(folder / "lv2"))
    return subprocess.run([tool, *args], env=env, capture_output=True, text=True, timeout=120)


def test_lv2info_lists_the_plugin_its_ports_and_controls(bundle):
    files = sorted(p.name for p in (bundle / "lv2" / "ks_in.lv2").iterdir())
    assert {"manifest.ttl", "ks_in.ttl", "ks_in.so"} <= set(files)
    proc = _lilv("lv2info", bundle, URI)
    assert proc.returncode == 0, proc.stderr
    info = proc.stdout
    assert "Karplus-Strong string fed from outside" in info
    for symbol in ("src_sample", "out_left", "out_right", "damp_gain", "mic_pan"):
        assert f"Symbol:      {symbol}" in info
    assert "#AudioPort" in info and "#ControlPort" in info and "hardRTCapable" in info
    damp = info[info.index("Symbol:      damp_gain"):]
    assert "Minimum:     -10.000000" in damp and "Default:     0.996000" in damp.split("Port")[0]


@pytest.mark.parametrize("controls", [(), (("damp_gain", 0.9), ("mic_pan", -0.5))])
def test_lv2apply_gives_the_samples_of_hapticgraph_rounded_to_float32(bundle, controls):
    args = ["-i", str(bundle / "input.wav"), "-o", str(bundle / "out.wav")]
    for symbol, value in controls:
        args += ["-c", symbol, repr(value)]
    proc = _lilv("lv2apply", bundle, *args, URI)
    assert proc.returncode == 0, proc.stderr
    got, rate = soundfile.read(bundle / "out.wav", dtype="float64")
    assert rate == 44100 and soundfile.info(bundle / "out.wav").subtype == "FLOAT"
    # a control port is a float: the plugin sets the parameter to that float's value
    sets = [f"{s.replace('_', '.', 1)}={float(np.float32(v))!r}" for s, v in controls]
    expected = hapticgraph.render(hapticgraph.load(bundle / "ks_in.yaml", overrides=sets), seconds=0.5).audio
    assert got.shape == expected.shape and np.abs(expected).max() > 0.1
    assert np.array_equal(got, expected.astype(np.float32).astype(np.float64))
    assert np.all(np.abs(got - expected) <= np.abs(expected) * 2.0 ** -24)
    if controls:
        plain = hapticgraph.render(bundle / "ks_in.yaml", seconds=0.5).audio
        assert not np.array_equal(got, plain.astype(np.float32).astype(np.float64))


def test_install_copies_the_bundle_into_the_users_lv2_folder(bundle, monkeypatch):
    home = bundle / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    assert main(["export", str(bundle / "ks_in.yaml"), "--to", "lv2", "--out", str(bundle / "again"),
                 "--name", "ks_home", "--install"]) == 0
    installed = home / ".lv2" / "ks_home.lv2"
    built = bundle / "again" / "ks_home.lv2"
    assert sorted(p.name for p in installed.iterdir()) == sorted(p.name for p in built.iterdir())
    proc = subprocess.run(["lv2info", "urn:hapticgraph:ks_home"], env=dict(os.environ, LV2_PATH=str(home / ".lv2")),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "Symbol:      damp_gain" in proc.stdout, proc.stderr


@pytest.mark.parametrize("args, said", [
    (["--to", "c", "--name", "9lives"], "--name '9lives': a C identifier is expected"),
    (["--to", "c", "--install"], "--install copies an LV2 bundle: use it with --to lv2"),
])
def test_usage_errors(bundle, capsys, args, said):
    assert main(["export", str(bundle / "ks_in.yaml"), "--out", str(bundle / "x"), *args]) == 2
    assert said in capsys.readouterr().err
    assert not (bundle / "x").exists()
