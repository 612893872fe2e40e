"""The simulated haptic device: a mass held by a scripted hand (spring + damper), pushed by the
patch's force, clamped to max_force; the same Driver interface a real device uses."""
import math

import numpy as np
import pytest

from hapticgraph import load, render
from hapticgraph.cli import main
from hapticgraph.devices import SimulatedDevice, open_drivers

HEAD = """
hapticgraph: 1
rate: 10000
devices:
  finger: {driver: simulated, max_force: 4.0, mass: 0.05, hand_stiffness: 400.0, hand_damping: DAMP,
           script: [{t: 0.0, x: 0.0}, {t: 0.1, x: 0.01}, {t: 0.5, x: 0.01}]}
blocks:
  pick: {type: haptic, device: finger}
  push: {type: constant, value: FORCE}
connect:
  - push.out -> pick.force
"""


def patch(write_patch, force=0.0, damping=4.0):
    return load(write_patch(HEAD.replace("FORCE", repr(force)).replace("DAMP", repr(damping))))


def test_follows_the_hand_and_deflects_by_force_over_stiffness(write_patch):
    r = render(patch(write_patch, force=1.0), 1.0, probes=["pick.x", "pick.v"])
    x = r.probes["pick.x"]
    # at rest after the script ends: x = x_hand + F/k_h = 0.01 + 1/400
    assert x[-1] == pytest.approx(0.01 + 1.0 / 400.0, rel=1e-6)
    assert abs(r.probes["pick.v"][-1]) < 1e-6
    # moving with the hand at 0.1 m/s near the end of the ramp: the start-up transient decays as
    # exp(−R/(2m)·t) = exp(−40 t), about 3 % at 90 ms (6 % allowed for its overshoot)
    assert r.probes["pick.v"][900] == pytest.approx(0.1, rel=0.06)


def test_force_is_clamped_to_max_force(write_patch):
    drivers = open_drivers(p := patch(write_patch, force=100.0))
    r = render(p, 1.0, probes=["pick.x"], drivers=drivers)
    assert r.probes["pick.x"][-1] == pytest.approx(0.01 + 4.0 / 400.0, rel=1e-6)
    sent = drivers["finger"].force_sent()
    assert sent.shape == (10000,) and np.all(sent == 4.0)


def test_nan_force_is_zeroed(write_patch):
    text = HEAD.replace("FORCE", "0.0").replace("DAMP", "4.0").replace(
        "  push: {type: constant, value: 0.0}",
        "  push: {type: constant, value: 0.0}\n  inv: {type: scale, in_range: [0, 0.5], out_range: [1, 2], clip: false}")
    p = load(write_patch(text))
    r = render(p, 0.05, probes=["pick.x"])
    assert np.all(np.isfinite(r.probes["pick.x"]))
    from hapticgraph.blocks.device import clamp_force
    assert clamp_force(math.nan, 4.0) == 0.0 and clamp_force(math.inf, 4.0) == 0.0
    assert clamp_force(-7.0, 4.0) == -4.0


def test_natural_frequency_of_mass_on_hand(write_patch):
    """Undamped: the device rings at √(k_h/m)/2π after the hand's ramp stops (to 0.5 %)."""
    r = render(patch(write_patch, damping=0.0), 1.0, probes=["pick.x"])
    x = r.probes["pick.x"][1200:] - 0.01
    crossings = np.where(np.diff(np.signbit(x)))[0]
    period = 2 * np.mean(np.diff(crossings)) / 10000.0
    assert 1 / period == pytest.approx(math.sqrt(400.0 / 0.05) / (2 * math.pi), rel=0.005)


def test_compiled_equals_interpreter_with_device(write_patch):
    p = patch(write_patch, force=0.5)
    a = render(p, 0.05, probes=["pick.x", "pick.v"])
    b = render(load(p.file), 0.05, probes=["pick.x", "pick.v"], engine="python")
    for k in a.probes:
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=0, atol=1e-12)


def test_script_interpolation_and_repeat():
    d = SimulatedDevice("f", {"script": [{"t": 0.0, "x": 0.0}, {"t": 1.0, "x": 1.0}, {"t": 2.0, "x": 0.0}],
                              "hold": False})
    x, v = d.hand(np.array([0.5, 1.5, 2.5, 3.25]))
    np.testing.assert_allclose(x, [0.5, 0.5, 0.5, 0.75])
    np.testing.assert_allclose(v, [1.0, -1.0, 1.0, -1.0])
    held = SimulatedDevice("f", {"script": [{"t": 0.0, "x": 0.0}, {"t": 1.0, "x": 1.0}]})
    x, v = held.hand(np.array([5.0]))
    assert x[0] == 1.0 and v[0] == 0.0


@pytest.mark.parametrize("text,line,needle", [
    ("devices:\n  finger: {script: [{t: 0.5, x: 0}, {t: 0.1, x: 0}]}\nblocks:\n  h: {type: haptic, device: finger}\n",
     3, "device 'finger': script keyframe at t = 0.1 s goes back in time"),
    ("blocks:\n  h: {type: haptic, device: thumb}\n", 3, "no device named 'thumb' under devices:"),
    ("blocks:\n  h: {type: haptic}\n", 3, "name the device"),
    ("devices:\n  finger: {max_force: -1}\nblocks:\n  h: {type: haptic, device: finger}\n", 3,
     "devices.finger.max_force: -1 must be greater than 0"),
    ("devices:\n  finger: {}\nblocks:\n  h: {type: haptic, device: finger}\n  g: {type: haptic, device: finger}\n",
     6, "device 'finger' is already bound to block 'h'"),
    ("devices:\n  finger: {}\nblocks:\n  h: {type: haptic, device: finger, max_force: 9}\n", 5,
     "unknown parameter 'max_force'"),
])
def test_device_patch_errors(tmp_path, capsys, text, line, needle):
    path = tmp_path / "d.yaml"
    path.write_text("hapticgraph: 1\n" + text.replace("\n  finger: {", "\n  finger: {", 1))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"d.yaml:{line}: " in err and needle in err, err


def test_script_axes_become_ports(write_patch):
    """Keys other than t and x in the keyframes are the device's other axes and buttons."""
    text = """
    hapticgraph: 1
    rate: 8000
    devices:
      joy: {driver: simulated, script: [{t: 0, x: 0, knob: 0.0, pedal: 0}, {t: 0.5, knob: 1.0, pedal: 1}]}
    blocks:
      js: {type: haptic, device: joy}
      g: {type: gain, gain: 2.0}
    connect:
      - js.knob -> g.in
      - js.pedal -> g.gain
    """
    p = load(write_patch(text))
    assert [o.name for o in p.blocks["js"].outputs] == ["x", "v", "knob", "pedal"]
    a = render(p, 1.0, probes=["js.knob", "g.out"])
    b = render(load(p.file), 1.0, probes=["js.knob", "g.out"], engine="python")
    np.testing.assert_allclose(a.probes["js.knob"][[0, 2000, 4000, 7999]], [0.0, 0.5, 1.0, 1.0])
    np.testing.assert_allclose(a.probes["g.out"][[0, 2000, 4000]], [0.0, 0.25, 1.0])
    for k in a.probes:
        np.testing.assert_array_equal(a.probes[k], b.probes[k])
