"""One local Dask cluster for the sweep tests of a module: 2 worker processes on 127.0.0.1, one
thread each, no dashboard, a task retried once when its worker dies; closed after the module."""
import logging

import pytest


@pytest.fixture(scope="module")
def dask_client():
    import dask
    from distributed import Client, LocalCluster
    from hapticgraph.sweeps import SCHEDULER_SETTINGS
    with dask.config.set(SCHEDULER_SETTINGS):
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None, silence_logs=logging.ERROR)
    try:
        with Client(cluster) as client:
            client.wait_for_workers(2, timeout=120)
            yield client
    finally:
        cluster.close(timeout=60)
