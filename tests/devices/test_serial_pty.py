"""Serial haptic devices over a real pseudo-terminal (no mock of the transport): the firmware
simulator speaks the shipped profiles' wire protocols; positions reach the patch, forces reach the
device clamped to max_force; unplug, garbage and silence zero the force and stop the run cleanly,
keeping what was rendered."""
import time

import numpy as np
import pytest
from hapticgraph.devices import open_drivers
from hapticgraph.devices.serial_port import FrameReader
from hapticgraph.devices.serial_profiles import (
    find_profile,
    load_profile,
    shipped_profiles,
)
from hapticgraph.devices.serial_sim import SerialSim
from hapticgraph.graph.engine import SafetyStop, Runner
from hapticgraph.graph.errors import PatchError

import hapticgraph

PATCH = """
hapticgraph: 1
rate: 8000
devices:
  dev: {driver: serial, profile: PROFILE, port: "PORT", max_force: LIMIT}
blocks:
  hand: {type: haptic, device: dev}
  wall: {type: spring_damper, k: 1000.0, R: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - hand.x -> wall.x1
  - wall.reaction -> hand.force
  - hand.x -> out.ch0
"""


def _session(write_patch, sim, profile="fader_1dof", limit=1.0, probes=()):
    text = PATCH.replace("PROFILE", profile).replace("PORT", sim.path).replace("LIMIT", str(limit))
    patch = hapticgraph.load(write_patch(text))
    return Runner(patch, probes=list(probes), drivers=open_drivers(patch), blocksize=64)


def _run(session, blocks):
    out = []
    for _ in range(blocks):
        time.sleep(session.blocksize / session.rate)
        out.append(session.process(session.blocksize).copy())
    return np.concatenate(out)


def test_shipped_profiles_load():
    assert {"fader_1dof", "pantograph_2dof"} <= set(shipped_profiles())
    fader = load_profile(find_profile("fader_1dof"))
    assert fader.ports == ("pos", "touch") and fader.max_force == 2.0


def test_frames_round_trip_and_resync():
    profile = load_profile(find_profile("pantograph_2dof"))
    sim = SerialSim(profile)
    try:
        frame = sim.frame({"px": 0.0123, "py": -0.004})
        reader = FrameReader(profile.input.framing)
        bad = bytearray(frame)
        bad[5] ^= 0xFF                                  # a corrupted frame is skipped, the next one read
        payloads = reader.feed(b"\x00\x13" + bytes(bad) + frame[:4]) + reader.feed(frame[4:])
        assert len(payloads) == 1
        assert profile.input.axes[0].value(payloads[0]) == pytest.approx(0.0123, abs=1e-9)
        assert profile.input.axes[1].value(payloads[0]) == pytest.approx(-0.004, abs=1e-9)
    finally:
        sim.close()


def test_positions_in_forces_out_clamped(write_patch):
    with SerialSim("fader_1dof", motion=lambda t: {"pos": 0.004, "touch": 1}) as sim:
        session = _session(write_patch, sim, limit=1.0, probes=["hand.touch", "wall.reaction"])
        try:
            rec = _run(session, 60)
        finally:
            session.stop()
        time.sleep(0.05)
    x, touch, reaction = rec[-1, 0], rec[-1, 1], rec[-1, 2]
    assert x == pytest.approx(0.004, abs=1e-5) and touch == 1.0
    assert reaction == pytest.approx(-4.0, rel=1e-3)          # k·x = 4 N asked for ...
    forces = [f for _, f in sim.forces]
    assert min(forces) == pytest.approx(-1.0, abs=1e-4)       # ... 1 N sent: the entry's max_force
    assert max(abs(f) for f in forces) <= 1.0 + 1e-4
    assert forces[-1] == 0.0                                  # the last word is zero force


@pytest.mark.parametrize("fault", ["unplug", "garbage", "silence"])
def test_faults_zero_the_force_and_stop(write_patch, fault):
    sim = SerialSim("fader_1dof", motion=lambda t: {"pos": 0.002})
    sim.start()
    session = _session(write_patch, sim, limit=2.0)
    kept = []
    try:
        kept.append(_run(session, 20))
        getattr(sim, fault)()
        with pytest.raises(SafetyStop, match="stopped answering"):
            for _ in range(400):
                kept.append(_run(session, 1))
    finally:
        session.stop()
        time.sleep(0.05)
        forces = [f for _, f in sim.forces]
        sim.close()
    rec = np.concatenate(kept)
    assert rec.shape[0] >= 20 * 64 and rec[-1, 0] == pytest.approx(0.002, abs=1e-5)   # what ran is kept
    if fault != "unplug":
        assert forces and forces[-1] == 0.0 and min(forces) < -1.0


def test_bad_profile_reported_at_its_line(write_patch, tmp_path):
    (tmp_path / "mine.yaml").write_text("serial_profile: 1\nmax_force: 1.0\ninput:\n  sync: [0xA5]\n"
                                        "  length: 2\n  interval: 0.001\n  timeout: 0.0005\n  position: pos\n"
                                        "  axes: {pos: {byte: 1, size: 16}}\noutput:\n  sync: [1]\n  length: 2\n"
                                        "  force: {byte: 0, size: 16, signed: true, scale: 100}\n")
    with pytest.raises(PatchError) as info:
        hapticgraph.load(write_patch(PATCH.replace("PROFILE", "mine.yaml").replace("PORT", "x")
                                     .replace("LIMIT", "1.0")))
    text = str(info.value)
    assert "mine.yaml:7: input.timeout" in text and "mine.yaml:9" in text
