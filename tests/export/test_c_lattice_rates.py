"""A lattice patch exported once serves any rate (issue 31): what its mass-spring groups derive
from the rate — the time step, a stencil's velocity scale (x[n] − x[n−1])·fs, a hammer's launch
sample — is computed again in C by NAME_new from the family's own Python, so the export run at
48 kHz gives the bits of the patch rendered at 48 kHz; and a rate at which the stability check
fails is refused there, NAME_refused saying it in the words `hapticgraph check` uses."""
import re

import numpy as np
import pytest

from hapticgraph.graph.errors import PatchError
from hapticgraph.graph.patch import load
from project_env import ROOT
from test_c_waveguides import LATTICES, python_run

OTHER, UNSTABLE = 48000, 2000      # every lattice patch is written at 44.1 kHz, and unstable at 2 kHz


def _at(path, rate):
    return re.sub(r"(?m)^rate: .*$", f"rate: {rate}", path.read_text(encoding="utf-8"))


@pytest.mark.parametrize("name", LATTICES)
def test_a_lattice_export_runs_at_another_rate_with_the_bits_of_python(name, c_export, same_bits):
    path = ROOT / "patches" / f"{name}.yaml"
    built = c_export(path)
    patch = load(path, text=_at(path, OTHER))
    assert patch.rate == OTHER and built.lowered.rate != OTHER
    audio, forces, inputs, rate = python_run(path, built.lowered, 0.25, 960, patch=patch)
    got = built.run(OTHER, len(audio), block=960, inputs=inputs)
    channels = audio.shape[1]
    assert np.abs(audio).max() > 0.0                      # it sounds
    assert same_bits(got[:, :channels], audio)
    assert same_bits(got[:, channels:], forces)
    at_own = built.run(built.lowered.rate, len(audio), block=960, inputs=inputs)
    assert not same_bits(at_own[:, :channels], audio)     # the rate matters


@pytest.mark.parametrize("name", LATTICES)
def test_an_unstable_rate_is_refused_in_the_words_of_check(name, c_export):
    path = ROOT / "patches" / f"{name}.yaml"
    built = c_export(path)
    with pytest.raises(PatchError) as refused:
        load(path, text=_at(path, UNSTABLE))
    expected = sorted(f"{path.name}:{p.line}: {p.message}" for p in refused.value.problems)
    assert any("unstable at 2000 Hz" in line for line in expected)
    assert sorted(built.refusal(UNSTABLE)) == expected
