"""Every block type that ships exports: the ones no shipped patch and no fuzzed graph of the
export's tests uses (a driven `point` and the `friction` link on general-path cells, the `reed`,
`osc_in` fed from the host, `velocity_estimator`, `audio_in`) give in C the bits of the Python
run, and no registered type is left out of some export test (the list below is checked against
the registry)."""
import numpy as np

import hapticgraph
from hapticgraph.graph.engine import Driver
from hapticgraph.graph.patch import load
from project_env import ROOT
from test_c_fuzzed import RANDOM_GRAPHS

POINTS = """
hapticgraph: 1
rate: 44100
blocks:
  hand: {type: point}
  bob: {type: cell, mass: 0.001, damping: 1.0}
  s: {type: spring, a: hand, b: bob, tension: 10000.0}
  rub: {type: friction, a: ground, b: bob, normal: 1.0, velocity: 0.5}
  lfo: {type: wavetable, shape: sine, frequency: 5.0, amplitude: 0.001}
  p: {type: constant, value: 900.0}
  r: {type: reed}
  est: {type: velocity_estimator, cutoff: 2000.0}
  out: {type: audio_out, channels: 6}
connect:
  - lfo.out -> hand.x
  - p.out -> r.pressure
  - bob.velocity -> r.v
  - bob.position -> est.in
  - hand.force -> out.ch0
  - bob.position -> out.ch1
  - rub.force -> out.ch2
  - r.force -> out.ch3
  - est.out -> out.ch4
  - hand.velocity -> out.ch5
"""

OSC = """
hapticgraph: 1
rate: 8000
devices:
  ctl: {driver: osc, port: 0}
blocks:
  fader: {type: osc_in, device: ctl, address: /fader/1}
  tone: {type: wavetable, shape: sine, frequency: 220.0, amplitude: 1.0}
  amp: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - tone.out -> amp.in
  - fader.out -> amp.gain
  - amp.out -> out.ch0
"""

# where each registered type is exported in the tests: a shipped patch, test_c_fuzzed.py's pool, or here
COVERED_HERE = {"point", "cell", "spring", "friction", "reed", "velocity_estimator", "osc_in"}
ELSEWHERE = {"audio_in": "test_lv2.py (ks_in.yaml) and test_lv2_patches.py"}


def test_point_friction_reed_and_estimator_give_the_bits_of_python(c_export, write_patch, same_bits):
    path = write_patch(POINTS)
    built = c_export(path)
    expected = hapticgraph.render(load(path), 0.2).audio
    assert (np.abs(expected).max(axis=0) > 0.0).all()                 # every output moves
    assert same_bits(built.run(44100, len(expected)), expected)


class Fader(Driver):
    """osc_in's column from an array (what an OSC hub's tap would write, sample by sample)."""

    columns = ("osc_value",)

    def __init__(self, values):
        self.name, self.values = "fader", values

    def fill(self, t0, ext):
        ext[:, 0] = self.values[t0:t0 + len(ext)]


def test_osc_in_reads_its_column_from_the_host(c_export, write_patch, same_bits):
    """An OSC controller is a device of the host: its column comes in `in` (kind cv)."""
    path = write_patch(OSC)
    built = c_export(path)
    assert [(p.name, p.kind) for p in built.lowered.inputs] == [("fader.osc_value", "cv")]
    fader = np.repeat(np.linspace(0.0, 1.0, 8), 100)
    expected = hapticgraph.render(load(path), 0.1, drivers={"fader": Fader(fader)}).audio
    assert np.abs(expected).max() > 0.5
    assert same_bits(built.run(8000, 800, block=100, inputs=fader[:, None]), expected)


def test_every_registered_type_is_exported_by_some_test():
    shipped = set()
    for path in (ROOT / "patches").glob("*.yaml"):
        shipped |= {b.cls.type_name for b in load(path).blocks.values()}
    types = set(load(ROOT / "patches" / "karplus_strong.yaml").registry.types)
    assert types - shipped - set(RANDOM_GRAPHS.POOL) - COVERED_HERE - set(ELSEWHERE) == set()
