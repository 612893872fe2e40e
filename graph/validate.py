"""The patch document against its JSON Schema (assembled from the block declarations and the
driver kinds), each violation told as FILE:LINE naming the block, parameter or key."""
from contextlib import closing

from .errors import suggest
from .explain import describe, whole_errors
from .schema import patch_schema
from .source import LDict, line_of


def check_schema(doc, registry, problems):
    blocks = doc.get("blocks")
    skip_blocks = set()
    if isinstance(blocks, LDict):
        for name, spec in blocks.items():
            if problems.full:
                return
            line = blocks.lines[name]
            if not isinstance(spec, LDict):
                continue
            kind = spec.get("type")
            if kind is None:
                problems.add(line, f"block {name!r}: no `type` (one of: {', '.join(sorted(registry.types))})")
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
    with closing(whole_errors(patch_schema(registry), doc)) as errors:
        _report_schema(errors, doc, registry, skip_blocks, problems)


def _report_schema(errors, doc, registry, skip_blocks, problems):
    for err in errors:
        if problems.full:
            return
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
