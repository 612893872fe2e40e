"""A numerical blow-up or a runaway zeroes the force sent to the hand in that very block, stops
the run with a clear message, and keeps everything rendered so far."""
import numpy as np
import pytest
from scipy.io import wavfile

from hapticgraph import load, render
from hapticgraph.cli import main
from hapticgraph.devices import open_drivers
from hapticgraph.graph.engine import SafetyStop

# a feedback loop with gain 2: doubles every 10 samples, overflows to inf within a second
BLOWUP = """
hapticgraph: 1
rate: 8000
devices:
  finger: {driver: simulated, max_force: 2.0}
blocks:
  kick: {type: pluck, duration: 0.001}
  loop: {type: delay, length: 10}
  amp: {type: gain, gain: 2.0}
  pick: {type: haptic, device: finger}
  soft: {type: gain, gain: 1e-30}
  out: {type: audio_out, channels: 1}
connect:
  - kick.out -> loop.in
  - amp.out -> loop.in
  - loop.out -> amp.in
  - amp.out -> soft.in
  - soft.out -> pick.force
  - soft.out -> out.ch0
"""


def test_blowup_zeroes_force_and_stops(write_patch):
    patch = load(write_patch(BLOWUP))
    drivers = open_drivers(patch)
    with pytest.raises(SafetyStop, match="numerical blow-up|runaway") as info:
        render(patch, 5.0, drivers=drivers, safety=True, chunk=256)
    partial = info.value.result
    kept = partial.audio.shape[0]
    assert 0 < kept < 5 * 8000
    # everything up to the sample where it was caught is kept; that sample is the first bad one
    free = render(load(write_patch(BLOWUP)), 5.0, chunk=256)
    np.testing.assert_array_equal(partial.audio, free.audio[:kept])
    assert np.all(np.abs(partial.audio) <= 1e3) and not np.abs(free.audio[kept, 0]) <= 1e3
    block = kept // 256 * 256                            # the faulty block starts here
    sent = drivers["finger"].force_sent()
    assert len(sent) == block + 256
    assert np.all(np.isfinite(sent)) and np.all(np.abs(sent) <= 2.0)
    assert np.all(sent[block:] == 0.0)                   # the faulty block sent no force at all


def test_run_keeps_what_was_rendered(write_patch, tmp_path, capsys):
    path = write_patch(BLOWUP.replace("length: 10", "length: 300"))   # blows up after the first block
    out = tmp_path / "blow.wav"
    assert main(["run", str(path), "--seconds", "5", "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "stopped after" in err and "the force sent was zeroed first" in err and "Traceback" not in err
    rate, data = wavfile.read(out)
    assert rate == 8000 and 0 < len(data) < 5 * 8000


def test_offline_render_without_safety_keeps_going(write_patch):
    patch = load(write_patch(BLOWUP))
    r = render(patch, 2.0, chunk=256)
    assert r.audio.shape[0] == 16000 and not np.all(np.isfinite(r.audio))


TWO_HANDS = """\
hapticgraph: 1
devices:
  a: {driver: simulated, max_force: 4.0, script: [{t: 0.0, x: 0.001}]}
  b: {driver: simulated, max_force: 4.0, script: [{t: 0.0, x: 0.001}]}
blocks:
  ha: {type: haptic, device: a}
  hb: {type: haptic, device: b}
  ka: {type: spring_damper, k: 1000.0, R: 0.0}
  kb: {type: spring_damper, k: 1000.0, R: 0.0}
connect:
  - ha.x -> ka.x1
  - ka.reaction -> ha.force
  - hb.x -> kb.x1
  - kb.reaction -> hb.force
"""


def test_a_lost_device_zeroes_the_force_of_every_device_in_its_block(write_patch):
    """One device stops answering: in that block every device is sent zero force (the forces
    were computed from stale inputs), then the run stops naming the lost one."""
    from hapticgraph.graph.engine import Runner
    patch = load(write_patch(TWO_HANDS))
    drivers = open_drivers(patch)
    sent = {name: [] for name in drivers}
    for name, driver in drivers.items():
        driver.send = lambda t0, force, name=name: sent[name].append(np.array(force))
    runner = Runner(patch, drivers=drivers, blocksize=32)
    runner.process(32)
    assert all(np.any(s[-1] != 0.0) for s in sent.values()), sent      # a pushing spring on each hand
    drivers["a"].lost = "unplugged"
    with pytest.raises(SafetyStop, match="device 'a' stopped answering: unplugged"):
        runner.process(32)
    assert all(len(s) == 2 and np.all(s[-1] == 0.0) for s in sent.values()), sent
    runner.stop()
