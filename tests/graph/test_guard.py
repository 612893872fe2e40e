"""Issue 13 (servo): the safety check and the force clamp run inside the kernel as one schedule item,
the guard (graph/guard.py), with one meaning for both engines; the runaway limit and each device's
max_force are data; and CompiledKernel.run's fast call gives the dispatcher's numbers."""
import math

import numpy as np
import pytest

from hapticgraph import load
from hapticgraph.devices import open_drivers
from hapticgraph.graph.engine import SafetyStop, Runner
from hapticgraph.graph.interpreter import Interpreter
from hapticgraph.graph.kernel import CompiledKernel
from hapticgraph.graph.program import Program

PUSH = """
hapticgraph: 1
rate: 8000
devices:
  finger: {{driver: simulated, max_force: {max_force}}}
blocks:
  push: {{type: constant, value: {value}}}
  pick: {{type: haptic, device: finger}}
  out: {{type: audio_out, channels: 1}}
connect:
  - push.out -> pick.force
  - pick.x -> out.ch0
"""


def _both(path, n=32, runaway=math.inf, probes=()):
    """(code, rec) of the compiled kernel and of the interpreter over the first n samples."""
    out = []
    for runner in (CompiledKernel, Interpreter):
        patch = load(path)
        prog = Program(patch, probes, open_drivers(patch))
        prog.guard.set_runaway(runaway)
        rec = np.zeros((n, len(prog.records)))
        code = runner(prog).run(0, rec, np.zeros((n, len(prog.ext_columns))))
        out.append((code, rec))
    return out


def test_each_force_is_clamped_to_its_device_in_the_kernel(write_patch):
    (code, rec), (ref_code, ref) = _both(write_patch(PUSH.format(max_force=2.0, value=10.0)), probes=["push.out"])
    assert code == ref_code == 0
    np.testing.assert_array_equal(rec, ref)
    assert np.all(rec[:, 2] == 2.0) and np.all(rec[:, 1] == 10.0)    # the force sent, the probe as it is
    (_, low), _ = _both(write_patch(PUSH.format(max_force=2.0, value=-10.0)))
    assert np.all(low[:, 1] == -2.0)
    (_, within), _ = _both(write_patch(PUSH.format(max_force=2.0, value=1.5)))
    assert np.all(within[:, 1] == 1.5)


def test_limits_are_data(write_patch):
    """Another max_force, another runaway limit: the same kernel."""
    keys = {CompiledKernel(Program(load(p), (), open_drivers(load(p)))).key
            for p in (write_patch(PUSH.format(max_force=2.0, value=1.0), "a.yaml"),
                      write_patch(PUSH.format(max_force=3.0, value=1.0), "b.yaml"))}
    assert len(keys) == 1
    path = write_patch(PUSH.format(max_force=3.0, value=1.0), "b.yaml")
    s1 = Runner(load(path), drivers=open_drivers(load(path)), runaway=1e3, blocksize=16)
    s2 = Runner(load(path), drivers=open_drivers(load(path)), runaway=0.5, blocksize=16)
    assert s1.engine.key == s2.engine.key in keys
    s1.process(16)
    with pytest.raises(SafetyStop, match=r"runaway: pick.force -> finger reached 1 at 0.0000 s, over the limit 0.5"):
        s2.process(16)


def test_a_bad_force_zeroes_the_block_and_names_itself(write_patch):
    path = write_patch(PUSH.format(max_force=2.0, value=1.0))
    (code, rec), (ref_code, ref) = _both(path, runaway=0.5)
    assert code == ref_code == 1 + 0 * 2 + 1        # sample 0, column 1: the force sent
    np.testing.assert_array_equal(rec, ref)
    assert np.all(rec[:, 1] == 0.0)                  # zeroed for the whole call
    s = Runner(load(path), drivers=open_drivers(load(path)), runaway=1e3, blocksize=8)
    s.prog.live[s.prog.by_name["push"].live["value"]] = math.nan    # past set_param's range check
    with pytest.raises(SafetyStop, match=r"numerical blow-up: pick.force -> finger is nan at 0.0000 s") as info:
        s.process(8)
    assert info.value.kept == 0 and np.all(s.rec[:8, 1] == 0.0)
    assert np.all(s.prog.drivers["finger"].force_sent() == 0.0)


LOOP = """
hapticgraph: 1
rate: 8000
blocks:
  kick: {type: pluck, duration: 0.001}
  loop: {type: delay, length: 1}
  amp: {type: gain, gain: 1e6}
connect:
  - kick.out -> loop.in
  - amp.out -> loop.in
  - loop.out -> amp.in
"""


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_state_that_is_not_finite_is_a_fault(write_patch):
    """Nothing recorded: the state array is checked after the loop, and a fault names its block."""
    (code, _), (ref_code, _) = _both(write_patch(LOOP), n=256)
    assert code == ref_code < 0
    s = Runner(load(write_patch(LOOP)), blocksize=256)
    with pytest.raises(SafetyStop, match=r"numerical blow-up: the state of block '(loop|amp)' is (inf|-inf|nan)") as info:
        s.process(256)
    assert info.value.kept == 256


def test_the_first_fault_wins_sample_then_column(write_patch):
    """A runaway in an earlier sample is caught before a NaN in a later one, in both engines."""
    path = write_patch(PUSH.format(max_force=4.0, value=1.0).replace("pick.x -> out.ch0", "push.out -> out.ch0"))
    for runner in (CompiledKernel, Interpreter):
        patch = load(path)
        prog = Program(patch, (), open_drivers(patch))
        prog.guard.set_runaway(0.5)
        rec = np.zeros((4, len(prog.records)))
        assert runner(prog).run(0, rec, np.zeros((4, len(prog.ext_columns)))) == 1   # sample 0, the audio
        assert prog.guard.describe(1, 0, 4) == ("runaway: out.ch0 reached 1 at 0.0000 s, over the limit 0.5", 0)


def test_the_fast_call_computes_what_the_dispatcher_does(patches_dir):
    """One sample a call with the same rec and ext (the entry point) against new arrays every call
    (the dispatcher): the same numbers, and the fast path was taken."""
    runs = []
    for fast in (True, False):
        patch = load(patches_dir / "fig7_bowed_string.yaml")
        drivers = open_drivers(patch)
        prog = Program(patch, (), drivers)
        k = CompiledKernel(prog)
        (device,) = drivers.values()
        device.start(prog.rate)
        rec, ext = np.zeros((1, len(prog.records))), np.zeros((1, len(prog.ext_columns)))
        rows = []
        for t in range(3000):
            if not fast:
                rec, ext = np.zeros_like(rec), np.zeros_like(ext)
            device.fill(t, ext)
            assert k.run(t, rec, ext) == 0
            rows.append(rec[0].copy())
        assert (k._rec is rec) == fast                        # new arrays every call: never remembered
        if fast:
            assert k._entry is next(iter(k.fn.overloads.values())).entry_point
        runs.append(np.array(rows))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.any(runs[0][:, 0] != 0.0)


def test_a_session_steps_one_sample_a_call_through_the_entry_point(patches_dir):
    """Session.process(1) hands the kernel the same views every call (made once per block size),
    so the entry point is used; the numbers are those of one block of 2,000 samples."""
    path = patches_dir / "fig7_bowed_string.yaml"
    fast = Runner(load(path), drivers=open_drivers(load(path)), blocksize=64)
    got = np.concatenate([fast.process(1).copy() for _ in range(2000)])
    assert fast.engine._rec is fast.views[1] and fast.engine._ext is fast.views[2]
    slow = Runner(load(path), drivers=open_drivers(load(path)), blocksize=2000)
    np.testing.assert_array_equal(got, slow.process(2000))
    np.testing.assert_array_equal(fast.prog.state, slow.prog.state)
    np.testing.assert_array_equal(fast.prog.drivers["arm"].force_sent(), slow.prog.drivers["arm"].force_sent())


def test_another_layout_goes_through_the_dispatcher(patches_dir):
    """A Fortran-ordered rec is another type: the dispatcher compiles its own overload, never the
    entry point of the C-ordered one; the same numbers."""
    path = patches_dir / "karplus_strong.yaml"
    runs = []
    for order in ("C", "F"):
        prog = Program(load(path))
        k = CompiledKernel(prog)
        rec = np.zeros((64, len(prog.records)), order=order)
        blocks = []
        for j in range(10):
            assert k.run(64 * j, rec, np.zeros((64, 0))) == 0
            blocks.append(rec.copy())
        runs.append(np.concatenate(blocks))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.any(runs[0] != 0.0)


KICK = """
hapticgraph: 1
rate: 8000
devices:
  finger: {{driver: simulated, max_force: {max_force}}}
blocks:
  push: {{type: constant, value: {push}}}
  kick: {{type: pluck, time: 0.002, force: 5.0, duration: 0.002}}
  pick: {{type: haptic, device: finger}}
  out: {{type: audio_out, channels: 1}}
connect:
  - push.out -> pick.force
  - {sound}.out -> out.ch0
"""


def test_a_runaway_later_in_the_call_zeroes_every_force_of_the_call(write_patch):
    """Forces are clamped sample by sample, the records checked once after the loop: a runaway in
    the audio at sample 17 gives the same code, message and zeroed forces in both engines."""
    path = write_patch(KICK.format(max_force=0.5, push=1.0, sound="kick"))
    (code, rec), (ref_code, ref) = _both(path, n=64, runaway=2.0, probes=["kick.out"])
    np.testing.assert_array_equal(rec, ref)
    assert code == ref_code and code > 0
    i, col = divmod(code - 1, 3)
    assert col == 0 and i > 16                      # the audio, once the pluck has risen past 2 N
    assert np.all(np.abs(rec[:i, 0]) <= 2.0) and not abs(rec[i, 0]) <= 2.0
    assert np.all(rec[:, 2] == 0.0)                  # the force sent: zeroed for the whole call
    prog = Program(load(path), ["kick.out"], open_drivers(load(path)))
    prog.guard.set_runaway(2.0)
    prog.coef[prog.guard.report] = rec[i, 0]
    message, kept = prog.guard.describe(code, 0, 64)
    assert kept == i and message.startswith(f"runaway: out.ch0 reached {abs(rec[i, 0]):.3g} at {i / 8000:.4f} s")


def test_a_probe_is_never_a_runaway_and_sound_forces_are_clamped(write_patch):
    path = write_patch(KICK.format(max_force=0.5, push=1.0, sound="push"))
    (code, rec), (ref_code, ref) = _both(path, n=64, runaway=2.0, probes=["kick.out"])
    np.testing.assert_array_equal(rec, ref)
    assert code == ref_code == 0
    assert rec[:, 1].max() > 2.0                     # the probe went past the limit: not a fault
    assert np.all(rec[:, 2] == 0.5)                  # every sample clamped


def test_a_force_over_the_limit_is_reported_as_it_was_not_clamped(write_patch):
    """max_force 0.2 < runaway 0.5 < the force 1.0: the message names 1, the force before the clamp."""
    path = write_patch(PUSH.format(max_force=0.2, value=1.0))
    (code, rec), (ref_code, ref) = _both(path, n=16, runaway=0.5)
    assert code == ref_code == 1 + 0 * 2 + 1
    np.testing.assert_array_equal(rec, ref)
    s = Runner(load(path), drivers=open_drivers(load(path)), runaway=0.5, blocksize=8)
    with pytest.raises(SafetyStop, match=r"runaway: pick.force -> finger reached 1 at 0.0000 s, over the limit 0.5"):
        s.process(8)
    assert np.all(s.prog.drivers["finger"].force_sent() == 0.0)
