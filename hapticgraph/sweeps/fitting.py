"""`hapticgraph fit`: the parameter values whose sound matches a recording.

The distance of a render x to the target y is a multi-resolution STFT distance (Yamamoto et al.
2020, Parallel WaveGAN: for FFT sizes 256, 1024 and 4096 with hop 1/4, the spectral convergence
‖|Y|−|X|‖/‖|Y|‖ plus the mean |log|Y| − log|X||, averaged over the sizes) plus the feature errors
|ln(f0_x / f0_y)| and |ln(t60_x / t60_y)| (1 when a feature is missing from one side), which give
the search a smooth basin where the spectra alone have many. scipy's `differential_evolution`
minimises it, each generation evaluated in parallel on the sweep's Dask workers (its `workers`
map), every evaluation a row of the results folder's manifest; the best values are written into
the text of the patch (only the value's text changes: comments and layout stay).
"""
import math
import os
import re

import numpy as np
import soundfile

from .features import centroid, f0, mono, t60
from ..graph.errors import Collector
from ..graph.patch import load as load_patch
from ..graph.registry import Registry
from ..graph.source import LDict, load_yaml, parse
from .check import check_variants, override
from .files import bundle_of
from .manifest import Manifest
from .spec import SweepSpec, Variant, read_axes, variant_id
from .runner import Tally, connect, submit_all

SIZES = (256, 1024, 4096)
MISSING = 1.0             # a feature error when one side has no value
FAILED = 1e3              # the distance of a variant that did not render (runaway, timeout, ...)


def stft_magnitudes(x, size):
    hop = size // 4
    if len(x) < size:
        x = np.pad(x, (0, size - len(x)))
    frames = np.lib.stride_tricks.sliding_window_view(x, size)[::hop]
    return np.abs(np.fft.rfft(frames * np.hanning(size), axis=1))


def spectral_distance(x, y, sizes=SIZES, eps=1e-7):
    """The multi-resolution STFT distance of mono signals x to y (same length)."""
    total = 0.0
    for size in sizes:
        sx, sy = stft_magnitudes(x, size), stft_magnitudes(y, size)
        convergence = np.linalg.norm(sy - sx) / max(np.linalg.norm(sy), eps)
        total += convergence + float(np.mean(np.abs(np.log(sy + eps) - np.log(sx + eps))))
    return total / len(sizes)


def _log_error(a, b):
    if not (math.isfinite(a) and math.isfinite(b)) or a <= 0 or b <= 0:
        return 0.0 if a == b else MISSING
    return abs(math.log(a / b))


class Score:
    """A render's distance to the target (its columns: distance, f0, t60, centroid), sent with each
    task and called by the worker on the render's audio."""

    def __init__(self, target, rate):
        self.target = mono(target)
        self.rate = rate
        self.f0, self.t60 = f0(self.target, rate), t60(self.target, rate)

    def __call__(self, audio, rate):
        x = mono(audio)[:len(self.target)]
        if len(x) < len(self.target):
            x = np.pad(x, (0, len(self.target) - len(x)))
        fx, tx = f0(x, rate), t60(x, rate)
        distance = spectral_distance(x, self.target) + _log_error(fx, self.f0) + _log_error(tx, self.t60)
        return {"distance": float(distance), "f0": fx, "t60": tx, "centroid": centroid(x, rate)}


class FitResult:
    """`values` ({block.param: value}), `distance`, `evaluations`, `patch_path` (the best patch
    written), `rows` (the manifest's rows of this fit)."""

    def __init__(self, **fields):
        self.__dict__.update(fields)


def read_axes_file(path, patch_path, registry, text=None):
    """(Axes of a fit, the patch) from an axes file (or its `text`): `block.param: {min: …, max: …,
    scale: linear|log}`, each checked against the patch (its two ends loaded) at the file's lines."""
    if text is None:
        doc, problems = load_yaml(path)
    else:
        problems = Collector(path)
        doc = parse(text, problems)
    problems.raise_if_any()
    base = load_patch(patch_path, registry=registry)
    axes = read_axes(doc, getattr(doc, "line", 1), base, problems)
    for axis in axes:
        if axis.low is None and not problems.problems:
            problems.add(axis.line, f"{axis.name}: a fit searches a range: give {{min: …, max: …}}")
    problems.raise_if_any()
    fields = {"patch": patch_path, "set": [], "sampler": "random", "patch_line": 1, "axes_line": 1}
    check_variants(fields, registry, axes, [], problems)
    problems.raise_if_any()
    return axes, base


def _axes_from_dict(axes, patch_path, registry):
    """The Axes of {name: (min, max)} (the Python API's form), checked as an axes file named <axes>."""
    text = "".join(f"{name}: {{min: {float(lo)!r}, max: {float(hi)!r}}}\n" for name, (lo, hi) in axes.items())
    return read_axes_file("<axes>", patch_path, registry, text)


def _target(path, rate, seconds):
    audio, file_rate = soundfile.read(os.fspath(path), dtype="float64", always_2d=True)
    if abs(file_rate - rate) > 1e-9:
        problems = Collector(os.fspath(path))
        problems.add(1, f"the target is at {file_rate:g} Hz and the patch at {rate:g} Hz; record or "
                        "resample the target at the patch's rate")
        problems.raise_if_any()
    seconds = min(len(audio) / rate, 2.0) if seconds is None else seconds
    return audio[:int(round(seconds * rate))], seconds


def fit(patch, target, axes, client=None, out=None, results=None, seed=1, popsize=10, maxiter=40, seconds=None,
        workers=None, scheduler=None, scheduler_file=None, progress=None, report=None, tol=0.01):
    """Fit `axes` (an axes file, or {block.param: (min, max)}) of `patch` (a path) to `target` (an
    audio file at the patch's rate). Returns a FitResult; the best patch is written to `out`
    (default PATCH_fit.yaml beside PATCH), every evaluation to `results`/manifest.csv."""
    from scipy.optimize import differential_evolution
    patch = os.fspath(patch)
    registry = Registry()
    if isinstance(axes, dict):
        axes_list, base = _axes_from_dict(axes, patch, registry)
        axes_file = patch
    else:
        axes_file = os.fspath(axes)
        axes_list, base = read_axes_file(axes_file, patch, registry)
    audio, seconds = _target(target, base.rate, seconds)
    stem = os.path.splitext(patch)[0]
    out = out or f"{stem}_fit.yaml"
    spec = _fit_spec(axes_file, axes_list, base, seconds, audio)
    manifest = Manifest(results or f"{stem}_fit", spec, resume=True)
    tally = Tally()
    try:
        with connect(client, workers, scheduler, scheduler_file) as dask_client:
            evaluate = _Evaluator(dask_client, spec, manifest, tally, Score(audio, base.rate))
            found = differential_evolution(evaluate.one, [(0.0, 1.0)] * len(axes_list), seed=seed,
                                           popsize=popsize, maxiter=maxiter, tol=tol, polish=False,
                                           updating="deferred", workers=evaluate.map)
    finally:
        manifest.close()
    values = {a.name: a.at(float(u)) for a, u in zip(axes_list, found.x)}
    write_patch(patch, out, base, values)
    (report or _stderr)(tally.note(manifest.path))
    return FitResult(values=values, distance=float(found.fun), evaluations=len(tally.rows), patch_path=out,
                     rows=manifest.table())


def _stderr(text):
    import sys
    print(f"hapticgraph fit: {text}", file=sys.stderr, flush=True)


def _fit_spec(axes_file, axes, base, seconds, audio):
    import hashlib
    h = hashlib.sha256()
    for part in (open(axes_file, "rb").read(), bundle_of(base)["digest"].encode(), np.ascontiguousarray(audio).tobytes()):
        h.update(hashlib.sha256(part).digest())
    return SweepSpec(file=axes_file, axes=axes, variants=[], bundle=bundle_of(base), rate=base.rate, digest=h.hexdigest(),
                     overrides=[], seconds=seconds, features={}, audio="none", timeout=None, sampler="de",
                     extra_columns=["distance", "f0", "t60", "centroid"])


class _Evaluator:
    """The objective on Dask: `map(func, population)` is differential_evolution's `workers`: each
    vector of the population becomes a variant rendered by the workers and a manifest row; `one`
    evaluates a single vector the same way."""

    def __init__(self, client, spec, manifest, tally, score):
        self.client, self.spec, self.manifest, self.tally = client, spec, manifest, tally
        self.score = score

    def _variant(self, u):
        values = tuple(a.at(float(x)) for a, x in zip(self.spec.axes, u))
        overrides = [override(a.name, v) for a, v in zip(self.spec.axes, values)]
        ident = variant_id(self.spec.bundle["digest"], overrides, self.spec.seconds, self.spec.rate)
        variant = Variant(len(self.spec.variants), values, overrides, ident)
        if ident not in self.tally.rows:
            self.spec.variants.append(variant)
        return variant

    def map(self, func, population):
        """The distances of a population, in order; a variant evaluated before (a step axis makes
        repeats) is not rendered again."""
        variants = [self._variant(u) for u in population]
        new = [v for v in {v.id: v for v in variants}.values() if v.id not in self.tally.rows]
        if new:
            submit_all(self.client, self.spec, new, self.manifest, False, self.score, self.tally)
        return [self._distance(self.tally.rows[v.id]) for v in variants]

    def one(self, u):
        return self.map(None, [u])[0]

    @staticmethod
    def _distance(row):
        value = row.get("distance")
        return float(value) if row.get("status") == "ok" and value is not None else FAILED


def write_patch(source, target, base, values):
    """Write the patch's text with each `block.param` set to its value (the value's text replaced
    where the patch gives it, else the parameter added to the block), and check it loads so."""
    with open(source, encoding="utf-8") as f:
        lines = f.read().split("\n")
    blocks = base.doc["blocks"]
    for name, value in values.items():
        block, param = name.split(".", 1)
        _set_value(lines, blocks, block, param, value)
    header = "# fitted by hapticgraph fit: " + ", ".join(override(n, v) for n, v in values.items())
    with open(target, "w", encoding="utf-8") as f:
        f.write("\n".join([header] + lines))
    check = load_patch(target, registry=base.registry)
    for name, value in values.items():
        block, param = name.split(".", 1)
        if check.blocks[block].values[param] != value:
            raise ValueError(f"{target}: {name} reads {check.blocks[block].values[param]!r}, not {value!r}")


def _set_value(lines, blocks, block, param, value):
    entry = blocks[block]
    text = override(param, value).partition("=")[2]
    if isinstance(entry, LDict) and param in entry:
        i = entry.lines[param] - 1
        pattern = re.compile(rf"(\b{re.escape(param)}\s*:\s*)([^,}}\s#]+|\[[^\]]*\])")
        lines[i], count = pattern.subn(lambda m: m.group(1) + text, lines[i], count=1)
        if count:
            return
        raise ValueError(f"cannot find the value of {block}.{param} on line {i + 1}")
    i = blocks.lines[block] - 1
    if "{" in lines[i] and "}" in lines[i]:
        at = lines[i].rindex("}")
        lines[i] = f"{lines[i][:at].rstrip()}, {param}: {text}{lines[i][at:]}"
    else:
        indent = len(lines[i + 1]) - len(lines[i + 1].lstrip()) if i + 1 < len(lines) else 4
        lines.insert(i + 1, " " * indent + f"{param}: {text}")
