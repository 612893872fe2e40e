"""The patch document against its JSON Schema (assembled from the block declarations and the
driver kinds), each violation told as FILE:LINE naming the block, parameter or key. A document
found clean is remembered (graph/verdicts.py): the same document is not checked again."""
from contextlib import closing

from .errors import suggest
from .explain import describe, whole_errors
from .schema import patch_schema
from .source import LDict, line_of
from .verdicts import recall, remember, verdict_key


def check_schema(doc, registry, problems):
    """Report every problem of the document against the schema; True if it has none (then each
    block spec holds only valid parameter values)."""
    before = len(problems.problems)
    skip_blocks = _check_types(doc, registry, problems)
    if skip_blocks is None:
        return False
    schema = patch_schema(registry)
    key = verdict_key(schema, doc) if len(problems.problems) == before else None
    if recall(key, doc):
        return True
    made = []
    with closing(whole_errors(schema, doc, made)) as errors:
        found = _report_schema(errors, doc, registry, skip_blocks, problems)
    clean = not found and len(problems.problems) == before
    if clean:
        remember(key, made)
    return clean


def _check_types(doc, registry, problems):
    """Each block's type and parameter names, told with suggestions; the blocks whose type is
    missing or unknown (their other problems are not told), or None when the problems are full."""
    blocks = doc.get("blocks")
    skip_blocks = set()
    if isinstance(blocks, LDict):
        for name, spec in blocks.items():
            if problems.full:
                return None
            line = blocks.lines[name]
            if not isinstance(spec, LDict):
                continue
            kind = spec.get("type")
            if kind is None:
                problems.add(line, f"block {name!r}: no `type` (one of: {', '.join(sorted(registry.types))})")
                skip_blocks.add(name)
            elif not isinstance(kind, str):
                problems.add(spec.lines.get("type", line),
                             f"block {name!r}: `type` must be a block type's name (text), not {kind!r:.40}")
                skip_blocks.add(name)
            elif kind not in registry.types:
                problems.add(spec.lines.get("type", line),
                             f"block {name!r}: unknown type {kind!r}{suggest(str(kind), registry.types)}")
                skip_blocks.add(name)
            else:
                cls = registry.types[kind]
                for key in spec:
                    if key != "type" and (key not in cls.params or cls.params[key].internal):
                        public = [n for n, p in cls.params.items() if not p.internal]
                        problems.add(spec.lines[key],
                                     f"block {name!r} ({kind}): unknown parameter {key!r}"
                                     f"{suggest(key, public)}")
    return skip_blocks


def _report_schema(errors, doc, registry, skip_blocks, problems):
    """Tell each error (those told elsewhere, with a suggestion, left out); True if there was any."""
    found = False
    for err in errors:
        found = True
        if problems.full:
            return found
        path = list(err.absolute_path)
        if len(path) >= 2 and path[0] == "blocks" and path[1] in skip_blocks:
            continue
        if err.validator == "additionalProperties" and len(path) == 2 and path[0] == "blocks":
            continue  # unknown parameters, reported above with a suggestion
        if err.validator in ("if", "allOf"):
            continue
        if len(path) == 3 and path[0] == "devices" and path[2] == "driver":
            continue  # an unknown driver, reported by _check_drivers with a suggestion
        problems.add(line_of(doc, path), describe(err, path, doc, registry))
    return found
