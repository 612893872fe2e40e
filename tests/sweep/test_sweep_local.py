"""Sweeps on a local Dask cluster of 2 worker processes (issue 23): rows and audio, faults as rows
(a runaway, a worker killed in the middle of a variant, a timeout), one kernel per structure per
worker, resume after --limit. Every test is bounded by the sizes of its sweeps."""
import csv
import math
import os
import signal
import threading
import time

import numpy as np
import pytest
import soundfile

import hapticgraph
from hapticgraph.sweeps import SweepError
from sweeps_env import crash_patch, karplus, lattice, write

COLUMNS = ["id", "status", "error", "loop.length", "damp.gain", "f0", "t60", "centroid", "rms", "peak", "audio",
           "seconds_compile", "seconds_run", "worker"]


def _rows(folder):
    with open(os.path.join(folder, "manifest.csv"), newline="") as f:
        return list(csv.DictReader(f))


def _quiet(notes):
    return lambda text: notes.append(text)


def test_grid_sweep_rows_features_audio_and_a_runaway(tmp_path, dask_client):
    karplus(tmp_path)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks.yaml
        seconds: 0.5
        axes:
          loop.length: [99, 199]
          damp.gain: [0.99, 0.995, 1.2]      # 1.2: the loop gains, a runaway
        set: [mic.pan=0.0]
        features: [f0, t60, centroid, rms, peak]
        audio: flac
        """)
    notes = []
    table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=_quiet(notes))
    rows = _rows(tmp_path / "out")
    with open(tmp_path / "out" / "manifest.csv") as f:
        assert f.readline().strip().split(",") == COLUMNS
    assert len(rows) == len(table) == 6
    for row in rows:
        if row["damp.gain"] == "1.2":
            assert row["status"] == "runaway" and "runaway" in row["error"] and row["audio"] == ""
            continue
        assert row["status"] == "ok", row
        length = float(row["loop.length"])
        assert float(row["f0"]) == pytest.approx(44100 / (length + 1), rel=2e-3)
        audio, rate = soundfile.read(tmp_path / "out" / row["audio"], always_2d=True)
        assert rate == 44100 and audio.shape == (22050, 2)
        assert float(row["peak"]) == pytest.approx(np.abs(audio).max(), rel=1e-5)
        assert row["worker"].startswith("tcp://127.0.0.1:")
    slow = {r["loop.length"]: float(r["t60"]) for r in rows if r["damp.gain"] == "0.995"}
    assert slow["199"] > slow["99"]                       # fewer passes a second: a longer decay
    assert "6 variant(s)" in notes[-1] and "4 ok" in notes[-1] and "2 runaway" in notes[-1]
    assert list(table["status"]).count("ok") == 4


def test_variants_of_numbers_re_use_one_kernel_per_worker(tmp_path, dask_client):
    """Numbers are data: 10 gains of one structure (mono: a structure no other test renders)
    build one kernel in each worker that renders any."""
    write(tmp_path, "ks4.yaml", (karplus(tmp_path).read_text().replace("channels: 2", "channels: 1")
                                 .replace("  - mic.right -> out.right\n", "").replace("out.left", "out.ch0")))
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: ks4.yaml
        seconds: 0.2
        axes:
          damp.gain: {min: 0.9, max: 0.999, count: 10}
        audio: none
        """)
    notes = []
    table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=_quiet(notes))
    assert list(table["status"]) == ["ok"] * 10
    built = int(notes[-1].split(" kernel(s) built for ")[0].rsplit(" ", 1)[1])
    assert 1 <= built <= 2, notes[-1]                   # one per worker that rendered any
    assert "for 10 variant(s) rendered" in notes[-1]
    assert list((tmp_path / "out" / "audio").iterdir()) == []       # audio: none


def test_a_worker_killed_by_its_variant_is_a_killed_row_and_the_rest_go_on(tmp_path, dask_client):
    crash_patch(tmp_path)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: crash.yaml
        seconds: 0.2
        axes:
          boom.die: [0.0, 1.0]
          damp.gain: [0.99, 0.995]
        features: [rms]
        audio: wav
        """)
    table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=lambda t: None)
    by_die = {}
    for _, row in table.iterrows():
        by_die.setdefault(row["boom.die"], []).append(row)
    assert [r["status"] for r in by_die[1.0]] == ["killed", "killed"]
    assert "died" in by_die[1.0][0]["error"]
    assert [r["status"] for r in by_die[0.0]] == ["ok", "ok"]
    dask_client.wait_for_workers(2, timeout=120)


def test_sigkill_of_a_worker_mid_sweep_loses_no_variant(tmp_path, dask_client):
    lattice(tmp_path, cells=400)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: string.yaml
        seconds: 2.0
        axes:
          s.damping: {min: 0.0001, max: 0.001, count: 8, scale: log}
        features: [rms]
        audio: none
        """)
    pids = sorted(dask_client.run(os.getpid).values())
    killed = []

    def kill_when_started():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            if any(dask_client.processing().values()):
                time.sleep(0.3)
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.05)
    killer = threading.Thread(target=kill_when_started, daemon=True)
    killer.start()
    try:
        table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=lambda t: None)
    finally:
        killer.join(timeout=130)
    assert killed
    assert len(table) == 8 and set(table["status"]) <= {"ok", "killed"}
    assert (table["status"] == "ok").sum() >= 6            # retried once on the other worker
    dask_client.wait_for_workers(2, timeout=120)
    assert pids[0] not in dask_client.run(os.getpid).values()


def test_a_render_past_its_timeout_stops_at_a_block_boundary(tmp_path, dask_client):
    lattice(tmp_path, cells=100)
    sweep = write(tmp_path, "s.yaml", """
        sweep: 1
        patch: string.yaml
        seconds: 600.0
        timeout: 0.5
        axes:
          s.mass: [0.001]
        audio: none
        """)
    started = time.monotonic()
    table = hapticgraph.sweep(sweep, tmp_path / "out", client=dask_client, report=lambda t: None)
    assert list(table["status"]) == ["timeout"]
    assert "over 0.5 s" in table["error"][0]
    assert time.monotonic() - started < 120               # 600 s of audio would take far longer


def test_resume_after_limit_skips_whole_variants_and_redoes_broken_ones(tmp_path, dask_client):
    karplus(tmp_path)
    text = """
        sweep: 1
        patch: ks.yaml
        seconds: 0.2
        sampler: lhs
        seed: 4
        count: 5
        axes:
          damp.gain: {min: 0.98, max: 0.999}
        features: [rms]
        audio: flac
        """
    sweep = write(tmp_path, "s.yaml", text)
    out = tmp_path / "out"
    first = hapticgraph.sweep(sweep, out, client=dask_client, limit=2, report=lambda t: None)
    assert len(first) == 2 and len(_rows(out)) == 2
    with pytest.raises(SweepError, match="--resume"):
        hapticgraph.sweep(sweep, out, client=dask_client, report=lambda t: None)
    whole = hapticgraph.sweep(sweep, out, client=dask_client, resume=True, report=lambda t: None)
    assert len(whole) == 5 and list(whole["status"]) == ["ok"] * 5 and len(_rows(out)) == 5
    broken = out / _rows(out)[0]["audio"]
    broken.write_bytes(broken.read_bytes()[:len(broken.read_bytes()) // 2])     # cut short
    again = hapticgraph.sweep(sweep, out, client=dask_client, resume=True, report=lambda t: None)
    assert len(_rows(out)) == 5 and list(again["status"]) == ["ok"] * 5          # its row replaced
    assert soundfile.info(broken).frames == int(0.2 * 44100)
    write(tmp_path, "s.yaml", text.replace("count: 5", "count: 6"))
    with pytest.raises(SweepError, match="changed since"):
        hapticgraph.sweep(tmp_path / "s.yaml", out, client=dask_client, resume=True, report=lambda t: None)
    assert math.isfinite(float(_rows(out)[0]["rms"]))
