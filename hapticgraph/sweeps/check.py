"""Every value of a sweep checked by the patch loader before anything is submitted: each axis
value on its own (for a sampled range: its ends), then every variant whole (what only a
combination shows: a lattice's stability needs its mass and its tension). The loader's problems,
which name the patch file, are told at the sweep file's line of the value (or of the `set:`
item) that caused them."""
import difflib
import json

from ..graph.errors import PatchError
from ..graph.patch import load as load_patch

MAX_REPORTED_VARIANTS = 5


def mapped(problem, fields, overrides):
    """(line, message) in the sweep file for a loader Problem of a patch loaded with `overrides`,
    [(text, sweep line, label or None)]: the override it names (its `--set` text, or its block
    and parameter), else the `patch:` line with the patch's own FILE:LINE."""
    message = problem.message
    for text, line, label in reversed(overrides):      # the last override of a parameter is the one in force
        target = text.partition("=")[0].strip()
        block, _, param = target.partition(".")
        quoted = f"--set {text!r}: "
        if message.startswith(quoted):
            return line, f"{target}: {_prefix(label)}{message[len(quoted):]}"
        if f"block {block!r}" in message and f"{param!r}" in message:
            return line, f"{text}: {_prefix(label)}{message}"
    for text, line, label in overrides:
        if f"block {text.partition('.')[0].strip()!r}" in message and label:
            return line, f"{_prefix(label)}{message}"
    label = next((lb for _, _, lb in overrides if lb), None)
    return fields["patch_line"], f"{_prefix(label)}in the patch: {problem}"


def override(name, value):
    """`block.param=VALUE` with the value as YAML flow text (json's text is YAML): exact floats."""
    return f"{name}={json.dumps(value)}"


def suggest(word, choices):
    """' (did you mean X?)' for the closest of choices, or ''."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _prefix(label):
    return f"{label}: " if label else ""


def _load_problems(fields, registry, overrides):
    """The loader's problems for the patch with these override texts ([] when it loads)."""
    try:
        load_patch(fields["patch"], overrides=overrides, registry=registry)
    except PatchError as exc:
        return list(exc.problems)
    return []


def _singles(axes, sampled):
    """(axis, value) pairs checked one by one: every listed value, a sampled range's two ends."""
    for axis in axes:
        if sampled and axis.low is not None:
            values = [axis.snap(axis.low), axis.snap(axis.high)]
            yield from ((axis, v, axis.range_line) for v in dict.fromkeys(values))
        else:
            seen = []
            for value, line in zip(axis.values, axis.lines):
                if value not in seen:
                    seen.append(value)
                    yield axis, value, line


def check_variants(fields, registry, axes, points, problems):
    """Record in `problems` (a Collector of the sweep file) every problem of a value or a variant."""
    fixed = [(t, line, None) for t, line in fields["set"]]
    sampled = fields["sampler"] != "grid"
    for axis, value, line in _singles(axes, sampled):
        text = override(axis.name, value)
        ours = fixed + [(text, line, None)]
        for problem in _load_problems(fields, registry, [t for t, _, _ in ours]):
            problems.add(*mapped(problem, fields, ours))
        if problems.full:
            return
    if problems.problems or (len(axes) == 1 and not sampled):
        return
    failing = 0
    for index, values in enumerate(points):
        label = f"variant {index} (" + ", ".join(f"{a.name}={json.dumps(v)}" for a, v in zip(axes, values)) + ")"
        ours = fixed + [(override(a.name, v), a.line_of(v), label) for a, v in zip(axes, values)]
        found = _load_problems(fields, registry, [t for t, _, _ in ours])
        if found:
            failing += 1
            if failing <= MAX_REPORTED_VARIANTS:
                for problem in found:
                    problems.add(*mapped(problem, fields, ours))
    if failing > MAX_REPORTED_VARIANTS:
        problems.add(fields["axes_line"], f"axes: {failing} variants in all do not load "
                                          f"(the first {MAX_REPORTED_VARIANTS} are shown)")
