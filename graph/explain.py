"""A patch document's JSON Schema errors, found (`whole_errors`, which also makes the floats the
schema takes as integers ints) and told as sentences naming the block, its parameter (with its
unit) or the key at fault (`describe`): what the loader reports at each error's line
(graph/validate.py, graph/voices.py)."""
from ..blocks.numbers import is_whole
from .model import connection_problem


def whole_errors(schema, doc, made=None):
    """The errors of `doc` against `schema` (JSON Schema 2020-12), as they are found. Every float the schema
    accepts as an integer (2.0: JSON Schema counts it as one) becomes an int in `doc`, in place,
    so an index, a count or a length reaches the blocks as the integer it means; a float with a
    fraction stays an error of the schema ("2.5 is not an integer", at its line). Floats are made
ints when the generator ends or is closed (a caller stopping early closes it: `closing`); the
path of each is appended to `made`, when given."""
    import jsonschema              # heavy (attrs, referencing, rpds): only when a document is checked
    from jsonschema import validators
    base = jsonschema.Draft202012Validator.VALIDATORS["type"]
    accepted = set()

    def type_(validator, types, instance, schema):
        errors = list(base(validator, types, instance, schema))
        named = [types] if isinstance(types, str) else list(types)
        if not errors and isinstance(instance, float) and "integer" in named and "number" not in named:
            accepted.add(id(instance))       # the document holds it, so the id stays its own
        return errors

    try:
        yield from validators.extend(jsonschema.Draft202012Validator, {"type": type_})(schema).iter_errors(doc)
    finally:
        if accepted:
            _make_whole(doc, accepted, (), [] if made is None else made)


def _make_whole(node, accepted, path, made):
    """Replace, in the lists and mappings of `node`, each float whose id is in `accepted` by its
    int; the path of each (from `path`) appended to `made`."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in list(items):
        if isinstance(value, float) and id(value) in accepted and is_whole(value):
            node[key] = int(value)
            made.append([*path, key])
        elif isinstance(value, (dict, list)):
            _make_whole(value, accepted, (*path, key), made)


def make_whole_at(doc, paths):
    """The floats at `paths` (whole_errors' `made`) made ints, as whole_errors made them; False
    (nothing changed) unless every path leads to a whole float."""
    found = []
    for path in paths:
        node = doc
        try:
            for key in path[:-1]:
                node = node[key]
            value = node[path[-1]]
        except (KeyError, IndexError, TypeError):
            return False
        if not (isinstance(value, float) and is_whole(value)):
            return False
        found.append((node, path[-1], value))
    for node, key, value in found:
        node[key] = int(value)
    return True


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
            cls = registry.lookup(kind)
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

