"""The patch document against its JSON Schema (assembled from the block declarations and the
driver kinds), each violation told as FILE:LINE naming the block, parameter or key."""
import jsonschema

from .errors import suggest
from .model import connection_problem
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
    validator = jsonschema.Draft202012Validator(patch_schema(registry))
    for err in validator.iter_errors(doc):
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


def describe(err, path, doc, registry):
    """A JSON Schema error of the document at `path`, told naming the block, parameter or key."""
    what, unit = "patch", ""
    if path and path[0] == "blocks" and len(path) >= 2:
        spec = doc["blocks"].get(path[1])
        kind = spec.get("type") if isinstance(spec, dict) else None
        what = f"block {path[1]!r}" + (f" ({kind})" if kind else "")
        if len(path) >= 3:
            what += f": parameter {path[2]!r}"
            rest = "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in path[3:])
            if rest:
                what += f" {rest.lstrip('.')}"
            cls = registry.types.get(kind)
            unit = cls.params[path[2]].unit if cls and path[2] in cls.params else ""
    elif path and path[0] == "connect":
        what = f"connection {err.instance!r}" if isinstance(err.instance, str) else "connect"
    elif path:
        what = ".".join(str(p) for p in path)
    v, s = err.instance, err.validator_value
    unit = f" {unit}" if unit else ""
    messages = {
        "minimum": lambda: f"{v!r} is below the minimum {s!r}{unit}",
        "maximum": lambda: f"{v!r} is above the maximum {s!r}{unit}",
        "exclusiveMinimum": lambda: f"{v!r} must be greater than {s!r}{unit}",
        "exclusiveMaximum": lambda: f"{v!r} must be less than {s!r}{unit}",
        "type": lambda: f"{v!r} is not {'an' if s[0] in 'aeiou' else 'a'} {s}",
        "enum": lambda: f"{v!r} is not one of {', '.join(map(repr, s))}",
        "const": lambda: f"{v!r} must be {s!r}",
        "minItems": lambda: f"needs at least {s} item(s), has {len(v)}",
        "maxItems": lambda: f"takes at most {s} item(s), has {len(v)}",
        "pattern": lambda: (connection_problem(v) if path and path[0] == "connect"
                            else f"{v!r} is not a valid name"),
        "required": lambda: f"missing {', '.join(repr(r) for r in s if r not in v)}",
        "additionalProperties": lambda: f"unknown key(s) {', '.join(repr(k) for k in v if k not in err.schema.get('properties', {}))}",
        "minLength": lambda: "must not be empty",
    }
    make = messages.get(err.validator)
    text = make() if make else err.message
    if err.validator == "pattern" and path and path[0] == "connect":
        return text
    return f"{what}: {text}"

