"""A JSON Schema error of a patch document told as a sentence naming the block, its parameter (with
its unit) or the key at fault: what the loader reports at the error's line (graph/validate.py,
graph/voices.py)."""
from .model import connection_problem


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

