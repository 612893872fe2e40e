"""The simulated hand's script runs inside the kernel (ScriptedHaptic): the same values as the
driver's numpy trajectory (the columns a take records, which SimulatedHaptic replays) to the bit,
on both engines; another script re-uses the compiled kernel; the driver's send keeps the force."""
import numpy as np
import pytest

from hapticgraph import load, render
from hapticgraph.devices import SimulatedDevice, open_drivers
from hapticgraph.devices.script import script_time, split_length
from hapticgraph.devices.simulated import ScriptedHaptic, SimulatedHaptic
from hapticgraph.graph import kernel

# a jump (two keyframes at 0.05 s), keyframes without `knob`, a `pedal` on a keyframe of its own,
# a script of 0.13 s that repeats: 0.2 s crosses the wrap at 2,600 samples
SCRIPT = ("[{t: 0.0, x: -0.01, knob: 0.5}, {t: 0.02, x: 0.004}, {t: 0.05, x: 0.006, knob: -1.0}, "
          "{t: 0.05, x: 0.0}, {t: 0.0901, x: 0.003, pedal: 2.0}, {t: 0.13, x: -0.01, knob: 0.25}]")
PATCH = """
hapticgraph: 1
rate: 20000
devices:
  finger: {{driver: simulated, max_force: 2.0, hand_stiffness: 900.0, script: {script}, hold: {hold}}}
blocks:
  pick: {{type: haptic, device: finger}}
  spring: {{type: spring_damper, k: 300.0, R: 0.5}}
  g: {{type: gain, gain: 1.5}}
connect:
  - pick.x -> spring.x1
  - pick.v -> spring.v1
  - spring.reaction -> pick.force
  - pick.knob -> g.in
  - pick.pedal -> g.gain
"""
PROBES = ["pick.x", "pick.v", "pick.knob", "pick.pedal", "g.out", "spring.force"]


class ColumnsDevice(SimulatedDevice):
    """The hand as columns the driver fills in numpy (what a take records), read by SimulatedHaptic."""
    block_type = SimulatedHaptic

    def block_values(self):
        return self.take_values()

    def start(self, rate):
        super().start(rate)
        self.recording = True


def _patch(write_patch, hold="false", script=SCRIPT, name="p.yaml"):
    return load(write_patch(PATCH.format(script=script, hold=hold), name))


@pytest.mark.parametrize("hold", ["false", "true"])
def test_the_kernel_follows_the_script_as_the_columns_do_to_the_bit(write_patch, hold):
    p = _patch(write_patch, hold)
    inside = render(p, 0.4, probes=PROBES, chunk=1000)
    columns = render(p, 0.4, probes=PROBES, chunk=1000,
                     drivers={"finger": ColumnsDevice("finger", p.devices["finger"])})
    for probe in PROBES:
        np.testing.assert_array_equal(inside.probes[probe], columns.probes[probe], err_msg=probe)
    knob = inside.probes["pick.knob"]
    assert knob[0] == 0.5 and knob[1000] == -1.0 and np.ptp(knob) > 1.0
    interpreted = render(p, 0.03, probes=PROBES, engine="python")
    for probe in PROBES:
        np.testing.assert_array_equal(interpreted.probes[probe], inside.probes[probe][:600], err_msg=probe)


def test_the_models_output_gives_the_drivers_trajectory_to_the_bit():
    """ScriptedHaptic.output, as the interpreter calls it, against the driver's numpy columns."""
    spec = {"script": [{"t": 0.0, "x": 0.0, "a": 1.0}, {"t": 0.3, "x": 1.0}, {"t": 0.3, "x": 0.5},
                       {"t": 0.7, "x": -2.0, "a": 3.0}, {"t": 1.1, "x": 0.1}]}
    for hold in (False, True):
        d = SimulatedDevice("f", {**spec, "hold": hold})
        d.start(441.0)
        expected = d._compute(-3, 2000)      # from before the script's start, over several repeats
        s, axis = d.script, np.zeros(1)
        rows = np.empty_like(expected)
        key = -1.0
        for i in range(2000):
            _, _, x, v, key = ScriptedHaptic.output(0.0, 0.0, i - 3, 441.0, s["repeat"], s["repeat_hi"],
                                                    s["repeat_lo"], s["times"], s["tracks"], s["slopes"], key, 1,
                                                    axis)
            rows[i] = x, v, axis[0]
        np.testing.assert_array_equal(rows, expected)


@pytest.mark.parametrize("length", [3.2, 0.13, 1 / 3, 1.6, 0.001, 97.123456789, 2.0])
@pytest.mark.parametrize("rate", [19000.0, 44100.0, 48000.0, 96000.0, 8000.0, 12345.678])
def test_the_repeated_scripts_time_is_np_mods_to_the_bit(length, rate):
    """script_time wraps without calling fmod; every sample of a long run, and large counters."""
    rng = np.random.default_rng(7)
    hi, lo = split_length(length)
    assert hi + lo == length
    t = np.concatenate([np.arange(0, 3000), rng.integers(0, 10 ** 10, 3000),
                        np.round(np.arange(1, 300) * length * rate).astype(np.int64) + rng.integers(-2, 3, 299)])
    t = t[t >= 0]
    got = np.array([script_time(int(k), rate, length, hi, lo) for k in t])
    np.testing.assert_array_equal(got.view(np.int64), np.mod(t / rate, length).view(np.int64))


def test_another_script_reuses_the_compiled_kernel(tmp_path, write_patch, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HAPTICGRAPH_CACHE", str(cache))
    monkeypatch.setattr(kernel, "_loaded", {})
    first = render(_patch(write_patch), 0.01, probes=["pick.x"])
    other = "[{t: 0.0, x: 0.2, knob: 3.0}, {t: 1.0, x: 0.1, pedal: 1.0}, {t: 2.0, x: 0.0}, {t: 2.5, x: 0.3}]"
    second = render(_patch(write_patch, hold="true", script=other, name="q.yaml"), 0.01, probes=["pick.x"])
    assert len([e for e in cache.iterdir() if e.name.startswith("kernel_")]) == 1
    assert first.probes["pick.x"][0] == -0.01 and second.probes["pick.x"][0] == 0.2


def test_force_sent_is_what_a_device_receives_and_keeps_the_latest(write_patch, monkeypatch):
    p = _patch(write_patch)
    monkeypatch.setattr(SimulatedDevice, "KEEP", 3000)
    drivers = open_drivers(p)
    r = render(p, 0.4, probes=["spring.reaction"], chunk=1024, drivers=drivers)
    sent = drivers["finger"].force_sent()
    np.testing.assert_array_equal(sent, np.clip(r.probes["spring.reaction"][-3000:], -2.0, 2.0))
    d = SimulatedDevice("f", {"max_force": 2.0})
    d.start(100.0)
    assert d.force_sent().shape == (0,)
    d.send(0, np.array([np.nan, np.inf, -np.inf, 5.0, -5.0, 1.5]))
    assert d.force_sent().tolist() == [0.0, 0.0, 0.0, 2.0, -2.0, 1.5]


def test_a_reload_that_changes_only_the_script_keeps_the_device_moving(write_patch):
    """--watch's carry_state: a new script carries the device's position and velocity over (the
    hand follows the new script from there); a new mass starts the device afresh."""
    from hapticgraph import Session
    from hapticgraph.devices.audio import carry_state

    def play_session(patch):          # as `play` opens it
        return Session.open(patch, blocksize=64, editable=False)
    old = play_session(_patch(write_patch))
    for _ in range(20):
        old.process(64)
    script = SCRIPT.replace("{t: 0.13, x: -0.01, knob: 0.25}", "{t: 0.13, x: 0.02, knob: 0.25}")
    q = _patch(write_patch, script=script, name="q.yaml")
    pairs, kept = carry_state(old.program, play_session(q).program)
    assert "pick" in kept and "spring" in kept
    heavier = load(write_patch(PATCH.format(script=SCRIPT, hold="false").replace("max_force: 2.0",
                                                                                 "max_force: 2.0, mass: 0.1"),
                               "h.yaml"))
    _, kept = carry_state(old.program, play_session(heavier).program)
    assert "pick" not in kept
