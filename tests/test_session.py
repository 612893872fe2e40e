"""The public Session (hapticgraph.Session, docs/api.md): the same samples as `render`, cells as
views of the running state, changes at block boundaries, a swap keeping unchanged blocks' state."""
import numpy as np
import pytest

import hapticgraph
from conftest import EDITABLE_STRING

SHEET = """
hapticgraph: 1
rate: 44100
blocks:
  plate: {type: lattice, shape: [6, 5], mass: 0.001, tension: 100000.0, damping: 0.01}
  hit: {type: pluck, time: 0.0, force: 0.5, duration: 0.0005}
  loop: {type: delay, length: 37}
  mic: {type: mic, gain: GAIN}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> plate[2, 2].force
  - plate[4, 3].velocity -> loop.in
  - loop.out -> mic.in
  - mic.left -> out.ch0
"""


def test_blocks_of_any_length_are_the_render(patches_dir):
    path = patches_dir / "karplus_strong.yaml"
    ref = hapticgraph.render(path, seconds=0.05, probes=["loop.out"])
    with hapticgraph.Session.open(path, probes=["loop.out"], blocksize=100) as s:
        parts = [s.process(n).copy() for n in (1, 100, 37, 450, 100, 3)]
        got = np.concatenate(parts)
        assert s.t == len(got) == 691
        assert np.array_equal(s.audio_of(got), ref.audio[:691])
        assert np.array_equal(s.probes_of(got)["loop.out"], ref.probes["loop.out"][:691])
        assert s.values("loop")["out"] == got[-1, 2]


def test_points_are_views_of_the_running_cells(write_patch):
    s = hapticgraph.Session.open(write_patch(EDITABLE_STRING), probes=["str[12].position"], blocksize=64)
    s.process(64)
    cells = s.points("str")
    assert cells.shape == (41,) and cells.positions.shape == (41,) and cells.cells.shape == (41, 1)
    cells.positions[:] = 0.0                  # hold the string flat, at rest: it stays so
    cells.velocities[:] = 0.0
    assert np.all(s.process(64)[:, 1] == 0.0)
    cells.positions[12] = 1e-3                # move one cell: the next block starts from there
    assert s.process(64)[0, 1] != 0.0
    assert not cells.locked.any() and not cells.cut.any()
    with pytest.raises(ValueError, match="not a lattice or cell block"):
        s.points("mic")


def test_changes_wait_for_the_block_boundary_and_report(write_patch):
    s = hapticgraph.Session.open(write_patch(EDITABLE_STRING), blocksize=32)
    s.process(32)
    done = []
    s.set("mic", "gain", 0.0, done=lambda text, error: done.append((text, error)))
    s.lock("str[20]", done=lambda text, error: done.append((text, error)))
    assert s.params("mic")["gain"] == 1.0 and not s.points("str").locked[20] and s.pending == 2
    assert np.all(s.process(32)[:, 0] == 0.0)       # applied before this block's first sample
    assert done == [("mic.gain = 0", None), ("lock str[20]", None)] and s.points("str").locked[20]
    for bad, needle in ((lambda: s.set("mic", "nope", 1), "not a live parameter"),
                        (lambda: s.set("mic", "pan", 3), "outside the range"),
                        (lambda: s.cut("str[99]"), "out of range"),
                        (lambda: s.unlock("str 3"), r"write a cell as NAME\[i, j\]"),
                        (lambda: s.values("nobody"), "no block named 'nobody'")):
        with pytest.raises(ValueError, match=needle):
            bad()
    assert s.pending == 0


def test_swap_keeps_the_state_of_unchanged_blocks(write_patch):
    """What --watch does, through the door: the unchanged blocks continue exactly."""
    a = write_patch(SHEET.replace("GAIN", "1.0"), name="a.yaml")
    b = write_patch(SHEET.replace("GAIN", "0.5"), name="b.yaml")
    with hapticgraph.Session.open(a, blocksize=64) as full:
        ref = np.concatenate([full.process(64)[:, 0].copy() for _ in range(40)])
    s = hapticgraph.Session.open(a, blocksize=64)
    first = np.concatenate([s.process(64)[:, 0].copy() for _ in range(20)])
    swap = s.swap(b)
    assert swap.kept == ["hit", "loop", "out", "plate"] and not swap.applied.is_set()
    second = np.concatenate([s.process(64)[:, 0].copy() for _ in range(20)])
    assert swap.wait(0) and s.swaps == 1 and s.params("mic")["gain"] == 0.5
    assert np.array_equal(first, ref[:1280])
    assert np.array_equal(second, ref[1280:] * 0.5) and np.any(second != 0)
    s.close()


def test_a_swap_to_another_rate_is_refused(write_patch):
    with hapticgraph.Session.open(write_patch(SHEET.replace("GAIN", "1.0"), name="a.yaml")) as s:
        other = write_patch(SHEET.replace("GAIN", "1.0").replace("rate: 44100", "rate: 48000"), name="r.yaml")
        with pytest.raises(ValueError, match="runs at 48000 Hz, the session at 44100 Hz"):
            s.swap(other)
        assert s.pending == 0


def test_a_withdrawn_swap_changes_nothing(write_patch):
    a = write_patch(SHEET.replace("GAIN", "1.0"), name="a.yaml")
    s = hapticgraph.Session.open(a, blocksize=64)
    s.process(64)
    swap = s.swap(write_patch(SHEET.replace("GAIN", "0.25"), name="c.yaml"))
    assert swap.wait(0.01) is False and s.pending == 0
    s.process(64)
    assert s.swaps == 0 and s.params("mic")["gain"] == 1.0
    s.close()


def test_devices_and_their_columns(patches_dir):
    with hapticgraph.Session.open(patches_dir / "fig7_bowed_string.yaml", devices={"arm": "simulated,mass=0.08"},
                                  blocksize=64) as s:
        s.process(64)
        assert s.inputs.shape[0] == 64 and s.forces.shape == (64, 1)
        assert "arm" in s.drivers
    with pytest.raises(hapticgraph.DeviceError, match="unknown setting"):
        hapticgraph.Session.open(patches_dir / "fig7_bowed_string.yaml", devices={"arm": "simulated,weight=1"})
    with pytest.raises(hapticgraph.PlanError, match="loop.nope"):
        hapticgraph.Session.open(patches_dir / "karplus_strong.yaml", probes=["loop.nope"])
    with pytest.raises(ValueError, match="overrides apply to a patch file"):
        hapticgraph.Session.open(hapticgraph.load(patches_dir / "karplus_strong.yaml"), overrides=["loop.length=3"])
