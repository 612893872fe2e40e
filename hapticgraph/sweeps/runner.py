"""Sweeps on Dask: every variant of a sweep file rendered by the workers of a Dask cluster (a local
one by default: one worker process per core), each result written by this client alone, as it
arrives, into the results folder (sweeps/manifest.py). A fault is a row, never the end of the sweep:
a variant whose worker dies (SIGKILL, out of memory) is retried once on another, then once more
alone, then `killed`.

    rows = hapticgraph.sweep("timbre.yaml", "out/")          # a local cluster
    rows = hapticgraph.sweep(spec, "out/", client=client)    # a cluster of yours
"""
import contextlib
import importlib.util
import logging
import os
import sys
import time
import uuid

from ..graph.progress import progress_bar
from .manifest import SAME_EACH_TIME, Manifest, SweepError, distinct
from .spec import SweepSpec, load_spec
from .worker import render_variant

ALLOWED_FAILURES = 1        # a task whose worker died is run once more, then reported `killed`
# The scheduler of a cluster the sweep starts. A worker's death counts against every task the
# scheduler had sent it, not only the one it was running; where the scheduler queues tasks (a
# sweep of more variants than twice the threads), one task a thread (a saturation of 1.0, not
# Dask's 1.1, which sends a one-thread worker a second one) sends no good variant behind a
# crashing one. What is sent anyway is sorted out by submit_all.
SCHEDULER_SETTINGS = {"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                      "distributed.scheduler.worker-saturation": 1.0}


def sweep(spec_or_path, out, client=None, workers=None, scheduler=None, scheduler_file=None, resume=False,
          limit=None, progress=None, report=None, retry_failed=False):
    """Render every variant of a sweep (a SweepSpec or a sweep file's path) into the folder `out`.

    `client`: a dask.distributed Client to use; else `scheduler` (an address) or `scheduler_file`
    names a running cluster, else a LocalCluster of `workers` processes (default: one per core) is
    started and stopped. `resume` continues the sweep of `out`: it renders the variants with no row
    yet and those whose row says `killed`, `timeout` or an `error` the cluster lost (no worker
    gave it), and keeps the rows that say `ok` (with a whole audio file), `runaway`, `invalid` or
    a worker's `error`: they give the same answer every time. `retry_failed` (with `resume`)
    renders those runaway, invalid and error variants again too. A variant rendered again replaces
    its row: the manifest keeps one row per variant id. `limit` renders at most that many of the
    variants still to do. `report(text)` receives the dashboard link and the closing note
    (default: standard error). Returns the manifest's rows of this sweep, one per variant id, in
    variant order: a pandas DataFrame when pandas is installed, else a list of dicts.
    Raises PatchError (FILE:LINE of the sweep file) before anything runs if a value is wrong,
    SweepError if `out` cannot be used as asked, ValueError for `retry_failed` without `resume`.
    """
    if retry_failed and not resume:
        raise ValueError("retry_failed renders again the failed variants of a sweep resumed: give resume=True too")
    spec = spec_or_path if isinstance(spec_or_path, SweepSpec) else load_spec(spec_or_path)
    report = report or _stderr
    manifest = Manifest(out, spec, resume)
    try:
        for note in manifest.notes:
            report(note)
        todo, kept = [], {}              # kept: {status: variants left as their rows say}
        for variant in distinct(spec.variants):
            if manifest.settled(variant, retry_failed):
                status = manifest.row_of(variant)["status"]
                kept[status] = kept.get(status, 0) + 1
            else:
                todo.append(variant)
        if limit is not None:
            todo = todo[:max(0, int(limit))]
        if todo:
            with connect(client, workers, scheduler, scheduler_file) as dask_client:
                if importlib.util.find_spec("bokeh") is not None and dask_client.dashboard_link:
                    report(f"Dask dashboard: {dask_client.dashboard_link}")
                tally = submit_all(dask_client, spec, todo, manifest, progress)
        else:
            tally = Tally()
        report(tally.note(manifest.path, kept))
    finally:
        manifest.close()
    return manifest.table()


def _stderr(text):
    print(f"hapticgraph sweep: {text}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def connect(client=None, workers=None, scheduler=None, scheduler_file=None):
    """The Dask client of a sweep: the one given, one of a running scheduler, or one of a local
    cluster (worker processes on 127.0.0.1, one thread each) made and closed here."""
    if client is not None:
        yield client
        return
    import dask
    from distributed import Client, LocalCluster
    if scheduler or scheduler_file:
        with Client(scheduler, scheduler_file=scheduler_file, timeout="30s") as c:
            yield c
        return
    n = int(workers or os.cpu_count() or 1)
    dashboard = "127.0.0.1:0" if importlib.util.find_spec("bokeh") is not None else None
    with dask.config.set(SCHEDULER_SETTINGS):
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=dashboard, silence_logs=logging.ERROR)
    try:
        with Client(cluster) as c:
            yield c
    finally:
        cluster.close()


class Tally:
    """What a sweep did: rows by status, and the kernels the workers built for them."""

    def __init__(self):
        self.statuses, self.kernels, self.compiled, self.workers, self.rendered = {}, 0, 0, set(), 0
        self.rows = {}
        self.started = time.perf_counter()

    def add(self, row):
        self.statuses[row["status"]] = self.statuses.get(row["status"], 0) + 1
        if row.get("kernel"):
            self.rendered += 1
            self.kernels += bool(row.get("kernel_new"))
            self.compiled += bool(row.get("kernel_compiled"))
            self.workers.add(row.get("worker"))

    @property
    def failed(self):
        return sum(n for status, n in self.statuses.items() if status != "ok")

    def note(self, path, kept=None):
        """The closing note; `kept`: {status: how many variants --resume left as their rows say}."""
        done = sum(self.statuses.values())
        seconds = time.perf_counter() - self.started
        parts = ", ".join(f"{n} {s}" for s, n in sorted(self.statuses.items())) or "nothing to render"
        text = f"{done} variant(s) in {seconds:.1f} s: {parts}"
        if kept:
            text += (f"; {sum(kept.values())} kept from the manifest ("
                     + ", ".join(f"{n} {s}" for s, n in sorted(kept.items())) + ")")
            if set(kept) & set(SAME_EACH_TIME):
                text += " (--retry-failed renders runaway, invalid and error variants again)"
        if self.rendered:
            text += (f"; {self.kernels} kernel(s) built for {self.rendered} variant(s) rendered on "
                     f"{len(self.workers)} worker(s) ({self.compiled} compiled by numba, the rest loaded "
                     f"from the kernel cache)")
        return f"{text}; manifest {path}"


def _job(spec, variant):
    return {"id": variant.id, "overrides": variant.overrides, "seconds": spec.seconds, "features": spec.features,
            "audio": spec.audio, "timeout": spec.timeout}


def submit_all(client, spec, todo, manifest, progress=None, score=None, tally=None):
    """Submit every variant of `todo` and write each row as its result arrives; the Tally (given or
    new) with `rows`, {variant id: row}. `score`: a fit's scorer, whose columns join each row.

    The patch's files go with each task rather than scattered once: data scattered to workers is
    lost for good when they die, and a sweep outlives its workers.

    Dask counts a worker's death against every task it had been sent, not only the one it was
    rendering, so a good variant sent behind one that kills its worker may come back `killed`
    too. A variant that comes back `killed` is therefore tried once more alone, once the others
    are done, and only its own death there makes its row `killed`."""
    from distributed import as_completed
    tally = tally or Tally()
    token = uuid.uuid4().hex[:8]

    def submit(variant, alone=""):
        return client.submit(render_variant, spec.bundle, _job(spec, variant), score,
                             key=f"hapticgraph-variant-{variant.id}-{token}{alone}", pure=False)
    futures = {submit(v): v for v in todo}
    bar = progress_bar(len(todo), "sweep", " variant", progress)
    suspects = []

    def take(future):
        variant = futures.pop(future)
        row, audio = _outcome(future, variant)
        future.release()
        if row["status"] == "killed" and variant not in suspects:
            suspects.append(variant)
            return
        manifest.write(variant, row, audio)
        tally.add(row)
        tally.rows[variant.id] = row
        bar.update(1)
        bar.set_postfix(failed=tally.failed, refresh=False)
    try:
        for future in as_completed(futures):
            take(future)
        for variant in list(suspects):
            future = submit(variant, "-alone")
            futures[future] = variant
            take(future)
    finally:
        bar.close()
        if futures:
            client.cancel(list(futures))
    return tally


def _outcome(future, variant):
    """(row, audio bytes) of a finished future; a worker that died is a `killed` row."""
    from distributed import KilledWorker
    try:
        return future.result()
    except KilledWorker as exc:
        return _row(variant, "killed", "its worker died while rendering it, each time it was tried, "
                                       f"the last time alone ({type(exc).__name__}: {exc})"), None
    except Exception as exc:  # noqa: BLE001 - lost by the cluster (cancelled, scheduler gone): a row
        # with no worker, which --resume renders again (an error a worker gave is kept)
        return _row(variant, "error", f"{type(exc).__name__}: {exc}"), None


def _row(variant, status, error):
    return {"id": variant.id, "status": status, "error": error, "audio": "", "seconds_compile": "",
            "seconds_run": "", "worker": ""}


__all__ = ["sweep", "connect", "submit_all", "Tally", "SweepError", "ALLOWED_FAILURES", "SCHEDULER_SETTINGS"]
