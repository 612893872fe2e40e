"""The README's tutorial instrument is real: it loads, plays headless and sounds at its pitch."""
import re

import pytest

from analysis import estimate_f0
from conftest import ROOT
from hapticgraph import load, render
from hapticgraph.devices import open_drivers


def _tutorial_patch():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    tutorial = text[text.index("## Tutorial"):]
    return re.search(r"```yaml\n(.*?)```", tutorial, re.S).group(1)


def test_tutorial_string_plucks_at_its_pitch(tmp_path):
    path = tmp_path / "my_string.yaml"
    path.write_text(_tutorial_patch())
    patch = load(path)
    drivers = open_drivers(patch)
    r = render(patch, 1.0, probes=["tip.force"], drivers=drivers)
    # the finger plucked: the plucker pulled up to its release force, then let go
    assert r.probes["tip.force"].max() == pytest.approx(0.5, rel=0.01)
    assert abs(drivers["finger"].force_sent()).max() <= 3.0
    y = r.audio[int(0.3 * r.rate):, 0]
    # round trip: 2·(20 + 78) delay + 2 (junction, one sample each way) + 1 (bridge) = 199 samples
    assert estimate_f0(y, r.rate) == pytest.approx(44100 / 199, rel=0.005)
