"""Sweeps and fits on Dask: many renders of one patch, each a row of a manifest.

    rows = hapticgraph.sweep("timbre.yaml", "out/")           # every variant of a sweep file
    best = hapticgraph.fit("plate.yaml", "take.wav", axes)     # the values whose render matches a take

What the package holds, from the file a user writes down to the numbers it compares:
spec.py (the sweep file: axes, grids, samplers, variants), check.py (its checks against the patch),
files.py (the files a variant reads, bundled for the workers), worker.py (one variant rendered
through hapticgraph.Session), manifest.py (the results folder, written by the client alone),
runner.py (the Dask side: connect, submit, tally), features.py (what a row measures of its audio;
also public as hapticgraph.features) and fitting.py (a fit: differential evolution over sweeps).
"""
from .features import register_feature
from .fitting import FitResult, fit
from .manifest import SweepError
from .runner import ALLOWED_FAILURES, SCHEDULER_SETTINGS, connect, sweep
from .spec import SweepSpec, load_spec

__all__ = ["ALLOWED_FAILURES", "SCHEDULER_SETTINGS", "FitResult", "SweepError", "SweepSpec", "connect", "fit",
           "load_spec", "register_feature", "sweep"]
