"""The Python API the README documents: load, check, render to arrays and the error classes to
catch, all importable from `hapticgraph`."""
import pathlib

import numpy as np
import pytest

import hapticgraph

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too

KS = ROOT / "patches" / "karplus_strong.yaml"

RUNAWAY = """
hapticgraph: 1
rate: 8000
blocks:
  kick: {type: pluck, time: 0.0, force: 1.0, duration: 0.001}
  loop: {type: delay, length: 10}
  grow: {type: gain, gain: 2.0}
  out:  {type: audio_out, channels: 1}
connect:
  - kick.out -> loop.in
  - grow.out -> loop.in
  - loop.out -> grow.in
  - loop.out -> out.ch0
"""


def test_every_documented_name_is_importable():
    from hapticgraph import (DeviceError, PatchError, PlanError, Problem, SafetyStop,  # noqa: F401
                             check, load, render)
    for cls in (PatchError, PlanError, SafetyStop, DeviceError):
        assert issubclass(cls, Exception)
    assert set(hapticgraph.__all__) <= set(dir(hapticgraph))
    with pytest.raises(AttributeError):
        hapticgraph.no_such_name  # noqa: B018


def test_load_check_render():
    patch = hapticgraph.load(KS)
    assert hapticgraph.check(KS) == []
    result = hapticgraph.render(patch, seconds=0.1, probes=["loop.out"])
    assert result.rate == 44100
    assert result.audio.shape == (4410, 2) and result.audio.dtype == np.float64
    assert result.probes["loop.out"].shape == (4410,)
    assert np.abs(result.audio).max() > 0.01
    # a path works as well as a Patch; overrides as `--set` takes them
    quiet = hapticgraph.render(KS, seconds=0.1, probes=["loop.out"])
    np.testing.assert_array_equal(quiet.audio, result.audio)
    assert hapticgraph.load(KS, overrides=["damp.gain=0.5"]).blocks["damp"].values["gain"] == 0.5


def test_check_lists_every_problem_and_load_raises_them(write_patch):
    bad = write_patch("hapticgraph: 1\nblocks:\n  a: {type: dealy}\n  c: {type: delay, length: -2}\nconnect: []\n")
    problems = hapticgraph.check(bad)
    assert [p.line for p in problems] == [3, 4]
    assert all(isinstance(p, hapticgraph.Problem) and p.file == str(bad) for p in problems)
    assert "did you mean 'delay'" in problems[0].message
    with pytest.raises(hapticgraph.PatchError) as err:
        hapticgraph.load(bad)
    assert [str(p) for p in err.value.problems] == [str(p) for p in problems]
    (problem,) = hapticgraph.check(KS, overrides=["loop.length=-3"])
    assert problem.line == 10 and "below the minimum" in problem.message


def test_errors_to_catch(write_patch):
    with pytest.raises(hapticgraph.PlanError, match="loop.nope"):
        hapticgraph.render(KS, seconds=0.01, probes=["loop.nope"])
    with pytest.raises(hapticgraph.SafetyStop):
        hapticgraph.render(write_patch(RUNAWAY), seconds=1.0, safety=True)
    with pytest.raises(hapticgraph.DeviceError):
        hapticgraph.render(ROOT / "patches" / "fig8_pluck_damp.yaml", seconds=0.01, devices={"finger": "nope"})
