"""The JSON Schema of a patch, assembled from every registered block type's declarations."""

IDENT = r"^[A-Za-z_][A-Za-z0-9_]*$"
ENDPOINT = r"[A-Za-z_][A-Za-z0-9_]*(\[[-0-9 ,]*\])?\.[A-Za-z_][A-Za-z0-9_]*"
CONNECTION = rf"^\s*{ENDPOINT}\s*->\s*{ENDPOINT}\s*$"
DRIVERS = ["simulated", "hid", "replay"]


def patch_schema(registry):
    names = sorted(registry.types)
    defs = {name: registry.types[name].schema() for name in names}
    block = {
        "type": "object",
        "required": ["type"],
        "properties": {"type": {"enum": names, "description": "the block type"}},
        "allOf": [{"if": {"properties": {"type": {"const": n}}, "required": ["type"]},
                   "then": {"$ref": f"#/$defs/{n}"}} for n in names],
    }
    device = {
        "type": "object",
        "properties": {"driver": {"enum": DRIVERS, "default": "simulated"}},
    }
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
        },
        "$defs": defs,
    }
