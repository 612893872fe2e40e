"""The same sweep on a loopback cluster — `dask scheduler` and two `dask worker` processes on
127.0.0.1, each with its own kernel cache folder — as on the local cluster and as single
`hapticgraph run --set …` renders: the same manifest values and the same audio, bit for bit
(issue 23, item 10). Every process started here is stopped by its PID."""
import contextlib
import csv
import os
import pathlib
import subprocess
import sys
import time

import dask
import numpy as np
import soundfile

from sweeps_env import crash_patch, karplus, write

import hapticgraph
from hapticgraph.sweeps import SCHEDULER_SETTINGS

ROOT = pathlib.Path(__file__).resolve().parents[2]

SWEEP = """
    sweep: 1
    patch: ks.yaml
    seconds: 0.3
    axes:
      loop.length: [99, 199]
      damp.gain: [0.99, 0.995]
    set: [mic.pan=0.25]
    features: [f0, t60, rms, peak]
    audio: wav
    """


# hapticgraph.sweeps.SCHEDULER_SETTINGS as environment variables of a `dask scheduler` (the README's)
SCHEDULER_ENV = {"DASK_" + key.upper().replace(".", "__").replace("-", "_"): str(value)
                 for key, value in SCHEDULER_SETTINGS.items()}


def test_the_readme_gives_a_scheduler_the_settings_of_a_sweeps_own_cluster():
    readme = (ROOT / "docs" / "sweeps.md").read_text()
    assert all(f"{name}={value}" in readme for name, value in SCHEDULER_ENV.items()), SCHEDULER_ENV
    parsed = dask.config.collect(paths=[], env=SCHEDULER_ENV)
    for key, value in SCHEDULER_SETTINGS.items():
        assert dask.config.get(key, config=parsed) == value


def _env(**more):
    env = dict(os.environ, HAPTICGRAPH_AOT="0", **more)
    env.pop("HAPTICGRAPH_DEBUG", None)
    return env


def _start(args, env, log):
    return subprocess.Popen([sys.executable, "-m", "dask", *args], env=env, stdout=log, stderr=subprocess.STDOUT)


def _stop(procs):
    for proc in procs:
        if proc.poll() is None:
            proc.terminate()
    for proc in procs:
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=30)


def _wait_for(path, procs, seconds=90):
    deadline = time.monotonic() + seconds
    while not os.path.exists(path):
        assert time.monotonic() < deadline, f"no {path} after {seconds} s"
        assert all(p.poll() is None for p in procs), "a dask process ended early"
        time.sleep(0.2)


@contextlib.contextmanager
def _loopback_cluster(tmp_path, workers):
    """A `dask scheduler` with the README's settings and a `dask worker` per entry of `workers`
    ((threads, environment it adds)) on 127.0.0.1: the scheduler file. Every process is stopped
    by its PID however the block ends."""
    scheduler_file = tmp_path / "scheduler.json"
    procs = []
    with open(tmp_path / "dask.log", "wb") as log:
        try:
            procs.append(_start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                 "--scheduler-file", str(scheduler_file)], _env(**SCHEDULER_ENV), log))
            _wait_for(scheduler_file, procs)
            for i, (threads, more) in enumerate(workers):
                procs.append(_start(["worker", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
                                     "--nthreads", str(threads), "--nworkers", "1", "--no-dashboard", "--name", f"w{i}"],
                                    _env(**more), log))
            yield scheduler_file
        finally:
            _stop(procs)


def _sweep(args, tmp_path, env):
    done = subprocess.run([sys.executable, "-m", "hapticgraph", "sweep", str(tmp_path / "s.yaml"), *args],
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stderr


def _manifest(folder):
    with open(folder / "manifest.csv", newline="") as f:
        return {row["id"]: row for row in csv.DictReader(f)}


def test_loopback_cluster_local_cluster_and_single_runs_agree_bit_for_bit(tmp_path):
    karplus(tmp_path)
    write(tmp_path, "s.yaml", SWEEP)
    workers = [(1, {"HAPTICGRAPH_CACHE": str(tmp_path / f"cache{i}")}) for i in range(2)]
    with _loopback_cluster(tmp_path, workers) as scheduler_file:
        note = _sweep(["--out", str(tmp_path / "cluster"), "--scheduler-file", str(scheduler_file)], tmp_path, _env())
    assert "4 ok" in note
    _sweep(["--out", str(tmp_path / "local"), "--workers", "2"], tmp_path, _env())
    cluster, local = _manifest(tmp_path / "cluster"), _manifest(tmp_path / "local")
    assert sorted(cluster) == sorted(local) and len(cluster) == 4
    assert {row["worker"] for row in cluster.values()} != {row["worker"] for row in local.values()}
    for ident, row in cluster.items():
        for column in ("status", "loop.length", "damp.gain", "f0", "t60", "rms", "peak", "audio"):
            assert row[column] == local[ident][column], column
        # the samples, bit for bit (a float WAV's PEAK chunk holds the time it was written)
        a, _ = soundfile.read(tmp_path / "cluster" / row["audio"], dtype="float32")
        b, _ = soundfile.read(tmp_path / "local" / row["audio"], dtype="float32")
        assert a.shape == b.shape == (13230, 2) and np.array_equal(a.view(np.uint32), b.view(np.uint32))
    assert any(os.listdir(tmp_path / f"cache{i}") for i in range(2))      # the workers' own caches
    for row in list(cluster.values())[:2]:
        single = tmp_path / f"single_{row['id']}.wav"
        sets = [f"loop.length={row['loop.length']}", f"damp.gain={row['damp.gain']}", "mic.pan=0.25"]
        done = subprocess.run([sys.executable, "-m", "hapticgraph", "run", str(tmp_path / "ks.yaml"), "--seconds", "0.3",
                               "--out", str(single), "--quiet", *[a for s in sets for a in ("--set", s)]],
                              env=_env(), capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        swept, _ = soundfile.read(tmp_path / "cluster" / row["audio"], dtype="float32")
        alone, _ = soundfile.read(single, dtype="float32")
        assert swept.shape == alone.shape and np.array_equal(swept.view(np.uint32), alone.view(np.uint32))


def test_a_good_variant_beside_one_that_kills_the_worker_is_not_killed(tmp_path):
    """A scheduler with the README's settings and one worker of two threads: a long render and one
    that kills the process as it is built run at once, so each death counts against both and Dask
    reports both KilledWorker. The good one, tried alone, comes back ok; the crashing one alone
    dies again: `killed`. (Without the try alone, both rows were `killed`.)"""
    crash_patch(tmp_path)
    sweep = write(tmp_path, "crash_sweep.yaml", """
        sweep: 1
        patch: crash.yaml
        seconds: 60
        axes:
          boom.die: [1.0, 0.0]
        features: [rms]
        audio: none
        """)
    with _loopback_cluster(tmp_path, [(2, {})]) as scheduler_file:
        table = hapticgraph.sweep(sweep, tmp_path / "out", scheduler_file=str(scheduler_file),
                                  report=lambda text: None, progress=False)
    status = {row["boom.die"]: row["status"] for _, row in table.iterrows()}
    assert status == {1.0: "killed", 0.0: "ok"}, table[["boom.die", "status", "error"]].to_dict("records")
    with open(tmp_path / "out" / "manifest.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 2               # one row each: a suspect is written once
