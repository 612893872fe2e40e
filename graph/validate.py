"""The patch document against its JSON Schema (assembled from the block declarations and the
driver kinds), each violation told as FILE:LINE naming the block, parameter or key."""
from contextlib import closing

import jsonschema
from jsonschema import validators

from ..blocks.numbers import is_whole
from .errors import _suggest
from .schema import patch_schema
from .source import LDict, line_of


def _check_schema(doc, registry, problems):
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
                             f"block {name!r}: unknown type {kind!r}{_suggest(str(kind), registry.types)}")
                skip_blocks.add(name)
            else:
                cls = registry.types[kind]
                for key in spec:
                    if key != "type" and (key not in cls.params or cls.params[key].internal):
                        public = [n for n, p in cls.params.items() if not p.internal]
                        problems.add(spec.lines[key],
                                     f"block {name!r} ({kind}): unknown parameter {key!r}"
                                     f"{_suggest(key, public)}")
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
        problems.add(line_of(doc, path), _describe(err, path, doc, registry))


_TYPE = jsonschema.Draft202012Validator.VALIDATORS["type"]


def whole_errors(schema, doc):
    """The errors of `doc` against `schema` (JSON Schema 2020-12), as they are found. Every float the schema
    accepts as an integer (2.0: JSON Schema counts it as one) becomes an int in `doc`, in place,
    so an index, a count or a length reaches the blocks as the integer it means; a float with a
    fraction stays an error of the schema ("2.5 is not an integer", at its line). Floats are made
ints when the generator ends or is closed (a caller stopping early closes it: `closing`)."""
    accepted = set()

    def type_(validator, types, instance, schema):
        errors = list(_TYPE(validator, types, instance, schema))
        named = [types] if isinstance(types, str) else list(types)
        if not errors and isinstance(instance, float) and "integer" in named and "number" not in named:
            accepted.add(id(instance))       # the document holds it, so the id stays its own
        return errors

    try:
        yield from validators.extend(jsonschema.Draft202012Validator, {"type": type_})(schema).iter_errors(doc)
    finally:
        if accepted:
            _make_whole(doc, accepted)


def _make_whole(node, accepted):
    """Replace, in the lists and mappings of `node`, each float whose id is in `accepted` by its int."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in list(items):
        if isinstance(value, float) and id(value) in accepted and is_whole(value):
            node[key] = int(value)
        elif isinstance(value, (dict, list)):
            _make_whole(value, accepted)


def _describe(err, path, doc, registry):
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
        "pattern": lambda: (_connection_problem_(v) if path and path[0] == "connect"
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


def _connection_problem_(text):
    from .patch import _connection_problem
    return _connection_problem(text)
