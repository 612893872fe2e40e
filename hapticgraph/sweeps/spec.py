"""The sweep file (docs/sweeps.md): read with the patch loader's line-keeping YAML
reader, every key and axis checked, the variants made by the sampler, and each variant's patch
loaded (with its overrides) before anything is submitted, so a bad value is a `FILE:LINE` of the
sweep file, never a failed task.

    sweep: 1
    patch: string.yaml            # relative to the sweep file; its plugin files travel with it
    seconds: 1.0
    sampler: grid                 # grid | random | lhs | sobol (scipy.stats.qmc), with seed
    seed: 1
    count: 64                     # for random, lhs, sobol
    axes:                         # block.param: a list of values, or a range
      loop.length: [99, 149, 199]
      damp.gain: {min: 0.99, max: 0.999, count: 4, scale: linear}   # log for decades
      # a range may have `step: 1` (values rounded to multiples of it): a number the kernel
      # holds as a literal (a delay's fractional length) compiles one kernel per value
    set: [mic.pan=0.0]            # fixed overrides, as --set
    features: [f0, t60, centroid, rms, peak]
    audio: flac                   # flac | wav | none
    timeout: 30                   # seconds of rendering per variant (optional)
"""
import hashlib
import itertools
import json
import math
import os
import re

import numpy as np

from .features import feature_table
from ..graph.errors import Collector, PatchError
from ..graph.patch import load as load_patch
from ..graph.registry import Registry
from ..graph.source import LDict, LList, load_yaml
from .check import check_variants, mapped, override, suggest as _suggest
from .files import bundle_of

SAMPLERS = ("grid", "random", "lhs", "sobol")
AUDIO = ("flac", "wav", "none")
KEYS = ("sweep", "patch", "seconds", "sampler", "seed", "count", "axes", "set", "features", "audio", "timeout")
RANGE_KEYS = ("min", "max", "count", "scale", "step")
MAX_VARIANTS = 1_000_000
_AXIS = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\.[A-Za-z_][A-Za-z0-9_]*")


class Axis:
    """One swept parameter: `name` (block.param), its `values` (a list axis, or a grid range's
    points), or `low`/`high`/`scale` (a range a sampler draws from); `line` of its key, `lines` of
    its values."""

    def __init__(self, name, line):
        self.name, self.line = name, line
        self.block, self.param = name.split(".", 1)
        self.values, self.lines = [], []
        self.low = self.high = None
        self.scale, self.integer, self.step = "linear", False, None

    def at(self, u):
        """The value at u in [0, 1) of a sampled axis."""
        if self.low is None:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        if self.scale == "log":
            value = self.low * (self.high / self.low) ** u
        else:
            value = self.low + u * (self.high - self.low)
        return self.snap(value)

    def snap(self, value):
        """A value on the axis's `step` (if it has one), whole for an integer parameter."""
        if self.step:
            value = min(max(round(value / self.step) * self.step, self.low), self.high)
        return int(round(value)) if self.integer else float(value)

    def line_of(self, value):
        for v, line in zip(self.values, self.lines):
            if v == value:
                return line
        return self.line


class Variant:
    """One point of the sweep: its number, its axis values, its overrides (set: then the axes) and id."""

    def __init__(self, index, values, overrides, ident):
        self.index, self.values, self.overrides, self.id = index, values, overrides, ident


class SweepSpec:
    """A checked sweep file. `variants` in order; `bundle` the patch and the files it reads;
    `extra_columns`: a fit's score columns."""

    extra_columns = ()

    def __init__(self, **fields):
        self.__dict__.update(fields)

    @property
    def axis_names(self):
        return [a.name for a in self.axes]


def load_spec(path):
    """The SweepSpec of a sweep file; PatchError (every problem, FILE:LINE of the sweep file)."""
    path = os.fspath(path)
    doc, problems = load_yaml(path)
    problems.raise_if_any()
    if not isinstance(doc, LDict):
        problems.add(getattr(doc, "line", 1), "a sweep file is a mapping that starts with `sweep: 1`")
        problems.raise_if_any()
    fields = _fields(doc, path, problems)
    if fields["patch"] is None:
        problems.raise_if_any()
    registry = Registry()
    before = len(problems.problems)
    base = _base_patch(fields, registry, problems)
    loaded = base is not None and len(problems.problems) == before     # with `set:` applied
    axes = read_axes(doc.get("axes"), doc.lines.get("axes", doc.line), base, problems) if base is not None else []
    points = _points(fields, axes, doc, problems) if axes else []
    if loaded:
        check_variants(fields, registry, axes, points, problems)
    problems.raise_if_any()
    fixed = [text for text, _ in fields["set"]]
    bundle = bundle_of(base)
    with open(path, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    variants = []
    for index, values in enumerate(points):
        overrides = fixed + [override(a.name, v) for a, v in zip(axes, values)]
        variants.append(Variant(index, values, overrides,
                                variant_id(bundle["digest"], overrides, fields["seconds"], base.rate)))
    return SweepSpec(file=path, doc=doc, axes=axes, variants=variants, bundle=bundle, rate=base.rate,
                     digest=digest, overrides=fixed, **{k: v for k, v in fields.items() if k != "set"})


def variant_id(bundle_digest, overrides, seconds, rate):
    """A variant's id: a hash of the patch and the files it reads, its overrides, duration and rate."""
    text = json.dumps([bundle_digest, list(overrides), repr(float(seconds)), repr(float(rate))])
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _number(doc, key, problems, default=None, positive=True, integer=False):
    value = doc.get(key, default)
    if value is None and key not in doc:
        return default
    kind = int if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, kind) or not math.isfinite(value) \
            or (positive and value <= 0) or (integer and value < 0):
        what = "a whole number" if integer else "a number"
        problems.add(doc.lines.get(key, doc.line), f"{key}: expected {what}"
                     f"{' above 0' if positive else ''}, got {value!r}")
        return default
    return value


def _choice(doc, key, choices, problems):
    value = doc.get(key, choices[0])
    if value not in choices:
        problems.add(doc.lines.get(key, doc.line), f"{key}: {value!r} is not one of {', '.join(choices)}"
                     f"{_suggest(str(value), choices)}")
        return choices[0]
    return value


def _fields(doc, path, problems):
    """The scalar keys of a sweep file, checked: a dict of them (and `set`: [(text, line)])."""
    for key in doc:
        if key not in KEYS:
            problems.add(doc.lines[key], f"unknown key {key!r}{_suggest(str(key), KEYS)}; a sweep file "
                                         f"has {', '.join(KEYS)}")
    if doc.get("sweep") != 1:
        problems.add(doc.lines.get("sweep", 1), "the first key must be `sweep: 1` (the sweep format version)")
    fields = {"seconds": _number(doc, "seconds", problems, 1.0),
              "sampler": _choice(doc, "sampler", SAMPLERS, problems),
              "audio": _choice(doc, "audio", AUDIO, problems),
              "seed": _number(doc, "seed", problems, 0, positive=False, integer=True),
              "timeout": _number(doc, "timeout", problems, None)}
    count = _number(doc, "count", problems, None, integer=True)
    if fields["sampler"] == "grid" and count is not None:
        problems.add(doc.lines["count"], "count: a grid has one variant per combination of its axes' "
                                         "values; count is for the random, lhs and sobol samplers")
    elif fields["sampler"] != "grid" and not count:
        problems.add(doc.lines.get("sampler", doc.line), f"sampler {fields['sampler']}: give `count:` "
                                                          "(how many variants to draw)")
    fields["count"] = count
    fields["patch"] = _patch_path(doc, path, problems)
    fields["patch_line"], fields["axes_line"] = doc.lines.get("patch", 1), doc.lines.get("axes", 1)
    fields["set"] = _set(doc, problems)
    fields["features"] = _features(doc, problems)
    return fields


def _patch_path(doc, path, problems):
    patch = doc.get("patch")
    where = doc.lines.get("patch", doc.line)
    if not isinstance(patch, str) or not patch:
        problems.add(where, "patch: give the patch file (relative to this sweep file)")
        return None
    full = os.path.join(os.path.dirname(os.path.abspath(path)), patch)
    if not os.path.isfile(full):
        problems.add(where, f"patch: no file {patch!r} beside the sweep file")
        return None
    return full


def _set(doc, problems):
    items = doc.get("set", LList())
    if not isinstance(items, LList):
        problems.add(doc.lines.get("set", doc.line), "set: expected a list of BLOCK.PARAM=VALUE")
        return []
    out = []
    for item, line in zip(items, items.lines):
        if not isinstance(item, str) or "=" not in item or not _AXIS.fullmatch(item.partition("=")[0].strip()):
            problems.add(line, f"set: {item!r}: expected BLOCK.PARAM=VALUE")
        else:
            out.append((item, line))
    return out


def _features(doc, problems):
    names = doc.get("features", LList())
    if not isinstance(names, LList):
        problems.add(doc.lines.get("features", doc.line), "features: expected a list of feature names")
        return {}
    table, chosen = feature_table(), {}
    for name, line in zip(names, names.lines):
        if name not in table:
            problems.add(line, f"features: unknown feature {name!r}{_suggest(str(name), table)}; "
                               f"known: {', '.join(sorted(table))}")
        elif name in chosen:
            problems.add(line, f"features: {name!r} is listed twice")
        else:
            chosen[name] = table[name]
    return chosen


def _base_patch(fields, registry, problems):
    """The patch with `set:` applied (its problems told at the sweep file's lines); else the patch
    alone, whose blocks the axes are checked against; None if that does not load either."""
    try:
        return load_patch(fields["patch"], overrides=[t for t, _ in fields["set"]], registry=registry)
    except PatchError as exc:
        for problem in exc.problems:
            problems.add(*mapped(problem, fields, [(t, line, None) for t, line in fields["set"]]))
    try:
        return load_patch(fields["patch"], registry=registry) if fields["set"] else None
    except PatchError:
        return None


def read_axes(axes_doc, line, patch, problems):
    """The Axis of each `block.param: values or range` of a mapping (checked against the patch)."""
    if not isinstance(axes_doc, LDict) or not axes_doc:
        problems.add(line, "axes: expected a mapping of block.param to a list of values or a range "
                           "{min, max, count, scale}")
        return []
    axes = []
    for name, spec in axes_doc.items():
        line = axes_doc.lines[name]
        if not _AXIS.fullmatch(name):
            problems.add(line, f"axes: {name!r}: write block.param")
            continue
        axis = Axis(name, line)
        if _target(axis, patch, problems):
            _axis_values(axis, spec, problems)
            axes.append(axis)
    return axes


def _target(axis, patch, problems):
    """True if the axis names a public parameter of a block of the patch (else a problem)."""
    inst = patch.blocks.get(axis.block)
    if inst is None:
        problems.add(axis.line, f"axes: {axis.name}: the patch has no block named {axis.block!r}"
                                f"{_suggest(axis.block, patch.blocks)}")
        return False
    public = [n for n, p in inst.cls.params.items() if not p.internal]
    if axis.param not in public:
        problems.add(axis.line, f"axes: {axis.name}: block {axis.block!r} ({inst.cls.type_name}) has no "
                                f"parameter {axis.param!r}{_suggest(axis.param, public)}; its parameters: "
                                f"{', '.join(public)}")
        return False
    axis.kind = inst.cls.params[axis.param].kind
    axis.integer = axis.kind == "integer"
    return True


def _axis_values(axis, spec, problems):
    if isinstance(spec, LList):
        if not spec:
            problems.add(axis.line, f"axes: {axis.name}: the list of values is empty")
        axis.values, axis.lines = list(spec), list(spec.lines)
        return
    if not isinstance(spec, LDict):
        problems.add(axis.line, f"axes: {axis.name}: expected a list of values or a range "
                                "{min: …, max: …, count: …, scale: linear|log}")
        return
    if axis.kind not in ("number", "integer"):
        problems.add(axis.line, f"axes: {axis.name}: a range needs a numeric parameter; "
                                f"{axis.param!r} is a {axis.kind}: list its values")
        return
    for key in spec:
        if key not in RANGE_KEYS:
            problems.add(spec.lines[key], f"axes: {axis.name}: unknown key {key!r} in a range"
                                          f"{_suggest(str(key), RANGE_KEYS)} (min, max, count, scale)")
    low = _number(spec, "min", problems, None, positive=False)
    high = _number(spec, "max", problems, None, positive=False)
    axis.scale = _choice(spec, "scale", ("linear", "log"), problems)
    axis.count = _number(spec, "count", problems, None, integer=True)
    axis.step = _number(spec, "step", problems, None)
    axis.range_line = spec.line
    if low is None or high is None:
        problems.add(spec.line, f"axes: {axis.name}: a range needs min and max")
    elif low > high:
        problems.add(spec.lines["min"], f"axes: {axis.name}: min {low!r} is above max {high!r}")
    elif axis.scale == "log" and low <= 0:
        problems.add(spec.lines["min"], f"axes: {axis.name}: a log scale needs min above 0")
    else:
        axis.low, axis.high = float(low), float(high)


def _points(fields, axes, doc, problems):
    """Every variant's axis values, in order: the grid's product (first axis slowest) or the
    sampler's points in the unit cube mapped onto each axis."""
    if fields["sampler"] == "grid":
        for axis in axes:
            if axis.low is not None:
                _grid_range(axis, problems)
        total = math.prod(len(a.values) for a in axes)
        if total > MAX_VARIANTS:
            problems.add(doc.lines["axes"], f"axes: the grid has {total:,} variants; a sweep holds at most "
                                            f"{MAX_VARIANTS:,}")
            return []
        return [tuple(p) for p in itertools.product(*(a.values for a in axes))]
    count = fields["count"] or 0
    if count > MAX_VARIANTS:
        problems.add(doc.lines["count"], f"count: at most {MAX_VARIANTS:,} variants")
        return []
    cube = unit_points(fields["sampler"], count, len(axes), fields["seed"])
    return [tuple(a.at(u) for a, u in zip(axes, row)) for row in cube]


def _grid_range(axis, problems):
    if not axis.count:
        problems.add(axis.range_line, f"axes: {axis.name}: a grid range needs count (its number of points)")
        return
    space = np.geomspace if axis.scale == "log" else np.linspace
    points = space(axis.low, axis.high, axis.count) if axis.count > 1 else np.array([axis.low])
    axis.values = list(dict.fromkeys(axis.snap(float(v)) for v in points))
    axis.lines = [axis.range_line] * len(axis.values)


def unit_points(sampler, count, dims, seed):
    """count × dims points in [0, 1): numpy's random generator, or scipy.stats.qmc's Latin
    hypercube or scrambled Sobol' sequence, seeded."""
    if sampler == "random":
        return np.random.default_rng(seed).random((count, dims))
    import warnings
    from scipy.stats import qmc
    engine = qmc.LatinHypercube(d=dims, seed=seed) if sampler == "lhs" else qmc.Sobol(d=dims, seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)     # Sobol' is best at powers of two; any count works
        return engine.random(count)


__all__ = ["load_spec", "read_axes", "SweepSpec", "Axis", "Variant", "override", "variant_id", "unit_points", "Collector"]
