"""`play --record` with a serial haptic device (the firmware simulator on a real pseudo-terminal,
play paced in real time by a `jackd -d dummy` server): the take re-renders offline (`run
--replay`) bit for bit; a fault mid-take (unplug, garbage, silence) zeroes the force, stops play
cleanly and keeps what was recorded: the take is readable and replays what was heard before the
stop."""
import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from audio_env import hapticgraph, jack_or_skip
from hapticgraph import load as hapticgraph_load
from hapticgraph.devices import open_drivers
from hapticgraph.devices.record import Take
from hapticgraph.graph.engine import render
from hapticgraph.devices.serial_sim import SerialSim
from scipy.io import wavfile

PATCH = """
hapticgraph: 1
rate: 44100
devices:
  dev: {driver: serial, profile: fader_1dof, port: "PORT", max_force: 1.0}
blocks:
  hand: {type: haptic, device: dev}
  wall: {type: spring_damper, k: 300.0, R: 0.5}
  tone: {type: wavetable, shape: sine, frequency: 330.0, amplitude: 0.5}
  amp: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - hand.x -> wall.x1
  - wall.reaction -> hand.force
  - tone.out -> amp.in
  - wall.reaction -> amp.gain
  - amp.out -> out.ch0
"""
FADE = 0.01          # s: play's mute ramp after a stop, in the WAV after the last rendered sample
COLUMNS = [["dev", "sensor_x"], ["dev", "sensor_v"], ["dev", "pos"], ["dev", "touch"], ["dev", "force"]]


def _motion(t):
    return {"pos": 0.004 * math.sin(2 * math.pi * 3 * t), "touch": int(t * 10) % 2}


@pytest.fixture
def jack(tmp_path):
    server = jack_or_skip(tmp_path)
    yield server
    server.stop()


def _play(path, take, env, *more):
    return subprocess.Popen([sys.executable, "-m", "hapticgraph", "play", path, "--blocksize", "64",
                             "--fade", str(FADE), "--audio-device", "system", "--record", take, *map(str, more)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _replay(tmp_path, path, take, env):
    again = tmp_path / "again.wav"
    r = hapticgraph(["run", path, "--replay", f"{take}.hgrec", "--out", again, "--quiet"], env)
    assert r.returncode == 0, r.stderr
    return wavfile.read(again)[1]


def test_serial_take_rerenders_bit_for_bit(tmp_path, write_patch, jack):
    with SerialSim("fader_1dof", motion=_motion) as sim:
        path = write_patch(PATCH.replace("PORT", sim.path))
        take = tmp_path / "take"
        proc = _play(path, take, jack.env, "--seconds", 1)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err
    t = Take(f"{take}.hgrec")
    assert t.header["columns"] == COLUMNS and t.frames == 44100
    info = t.header["drivers"]["dev"]
    assert info["kind"] == "serial" and info["model"] is None and info["max_force"] == 1.0
    pos = t.inputs[:, 2]
    assert pos.max() > 0.003 and pos.min() < -0.003                 # the fader moved, frame by frame
    assert set(np.unique(t.inputs[:, 3])) == {0.0, 1.0}
    force = t.force_of("dev")
    assert np.abs(force).max() > 0.5                                # the wall pushed back
    assert max(abs(f) for _, f in sim.forces) <= 1.0 + 1e-4 and sim.forces[-1][1] == 0.0
    _, heard = wavfile.read(f"{take}.wav")
    assert np.abs(heard).max() > 0.1
    replayed = _replay(tmp_path, path, take, jack.env)
    assert np.array_equal(replayed.view(np.uint32), heard.view(np.uint32))
    # a device entry `driver: replay` feeds the device from the take; what it would have sent is
    # clamped to the bound the serial device had (the take's), as the device received it; the
    # take holds the force as the kernel clamped it (the wall pushed harder than 1 N)
    replay = hapticgraph_load(write_patch(PATCH.replace(
        '{driver: serial, profile: fader_1dof, port: "PORT", max_force: 1.0}', "{driver: replay, file: take.hgrec, axes: [pos, touch]}"),
        name="replay.yaml"))
    drivers = open_drivers(replay)
    render(replay, seconds=t.seconds, drivers=drivers)
    sent = drivers["dev"].force_sent()
    assert np.abs(sent).max() == 1.0 and np.abs(force).max() == 1.0 and np.mean(np.abs(force) == 1.0) > 0.01


def _wait_for_rows(proc, hgrec, rows):
    """Until the take holds about `rows` samples (the recorder writes every 0.2 s) or play ended."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if os.path.exists(hgrec) and os.path.getsize(hgrec) > rows * 8 * len(COLUMNS):
            return
        time.sleep(0.05)


@pytest.mark.parametrize("fault", ["unplug", "garbage", "silence"])
def test_fault_mid_take_keeps_the_take(tmp_path, write_patch, jack, fault):
    sim = SerialSim("fader_1dof", motion=lambda t: {"pos": 0.003, "touch": 1})
    sim.start()
    try:
        path = write_patch(PATCH.replace("PORT", sim.path))
        take = tmp_path / "take"
        proc = _play(path, take, jack.env, "--seconds", 60)
        _wait_for_rows(proc, f"{take}.hgrec", 22050)
        assert proc.poll() is None, proc.communicate()[1]
        getattr(sim, fault)()
        out, err = proc.communicate(timeout=120)
        forces = [f for _, f in sim.forces]
    finally:
        sim.close()
    assert proc.returncode == 1 and "stopped answering" in err and "Traceback" not in err, err
    assert "recorded" in out
    t = Take(f"{take}.hgrec")                                       # a complete, readable take
    _, heard = wavfile.read(f"{take}.wav")
    nfade = round(FADE * 44100)
    good = len(heard) - nfade                                       # rendered before the stop, then the fade
    assert good >= 22050 and 0 < t.frames - good <= 64              # the stopped block's inputs are kept
    assert np.all(t.force_of("dev")[good:] == 0.0)                  # no force in the stopped block
    assert t.force_of("dev")[good - 1] == pytest.approx(-0.9, abs=1e-3)     # k·x asked before it
    assert np.all(np.abs(heard[good:]) <= np.abs(heard[good - 1])) and heard[-1] == 0.0
    if fault != "unplug":                                           # the device heard zero force last
        assert forces[-1] == 0.0 and min(forces) < -0.5
    replayed = _replay(tmp_path, path, take, jack.env)
    assert len(replayed) == t.frames
    assert np.array_equal(replayed[:good].view(np.uint32), heard[:good].view(np.uint32))
