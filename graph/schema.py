"""The JSON Schema of a patch, assembled from every registered block type's declarations."""
from .patterns import CONNECTION, END, ENDPOINT, IDENT, INDEX, WHOLE  # noqa: F401  (the patterns the schema uses)
from .voices import voices_schema


def device_schema(drivers):
    """A device entry: its `driver:` and the settings that driver reads, from each driver kind's
    declaration (`drivers`: name -> kind; see hapticgraph.graph.registry). The loader reports an
    unknown driver itself, with a suggestion, even when no driver is available."""
    default = next((k.name for k in drivers.values() if k.default), None)
    driver = {"enum": list(drivers)} if drivers else {"type": "string"}
    if default is not None:
        driver["default"] = default
    clauses = []
    for kind in drivers.values():
        when = {"properties": {"driver": {"const": kind.name}}}
        if kind.default:
            when["type"] = "object"          # also an entry without `driver:`
        else:
            when["required"] = ["driver"]
        then = {"properties": {"driver": driver, **kind.settings()}}
        if kind.required:
            then["required"] = list(kind.required)
        if kind.closed:
            then["additionalProperties"] = False
        clauses.append({"if": when, "then": then})
    schema = {"type": "object", "properties": {"driver": driver}}
    if clauses:
        schema["allOf"] = clauses
    return schema


def _sections(drivers):
    """Top-level sections driver kinds add to a patch (optional `sections()`: key -> schema)."""
    out = {}
    for kind in drivers.values():
        out.update(getattr(kind, "sections", dict)())
    return out


def patch_schema(registry):
    names = sorted(registry.types)
    defs = {name: registry.types[name].schema() for name in names}
    block = {
        "type": "object",
        "required": ["type"],
        "properties": {"type": {"enum": names, "description": "the block type"}},
        "allOf": [{"if": {"type": "object", "properties": {"type": {"const": n}}, "required": ["type"]},
                   "then": {"$ref": f"#/$defs/{n}"}} for n in names],
    }
    device = device_schema(getattr(registry, "drivers", {}))
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://hapticgraph.invalid/patch-1.schema.json",
        "title": "hapticgraph patch (format version 1)",
        "type": "object",
        "required": ["hapticgraph", "blocks"],
        "additionalProperties": False,
        "properties": {
            "hapticgraph": {"const": 1, "description": "patch format version"},
            "name": {"type": "string"},
            "rate": {"type": "number", "minimum": 100, "maximum": 1_000_000, "default": 44100,
                     "description": "the kernel's step rate [samples/s]"},
            "plugins": {"type": "array", "items": {"type": "string", "minLength": 1}},
            "devices": {"type": "object", "propertyNames": {"pattern": IDENT},
                        "additionalProperties": device},
            "blocks": {"type": "object", "propertyNames": {"pattern": IDENT},
                       "additionalProperties": block},
            "connect": {"type": "array", "items": {"type": "string", "pattern": CONNECTION}},
            "voices": voices_schema(block),
            **_sections(getattr(registry, "drivers", {})),
        },
        "$defs": defs,
    }
