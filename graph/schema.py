"""The JSON Schema of a patch, assembled from every registered block type's declarations."""

# Patterns are ECMA-262 (for editors) and read by Python's re.search, whose `$` also matches
# before a final newline: `(?![\s\S])` anchors at the very end in both, so a name is matched whole.
END = r"(?![\s\S])"
IDENT = rf"^[A-Za-z_][A-Za-z0-9_]*{END}"
INDEX = r"\[ *-?[0-9]{1,18} *(, *-?[0-9]{1,18} *)*\]"
ENDPOINT = rf"[A-Za-z_][A-Za-z0-9_]*({INDEX})?\.[A-Za-z_][A-Za-z0-9_]*"
CONNECTION = rf"^\s*{ENDPOINT}\s*->\s*{ENDPOINT}\s*{END}"
DRIVERS = ["simulated", "hid", "replay"]


def device_schema():
    """A device entry: the driver and its settings (the simulated device is the default)."""
    number = {"type": "number"}
    keyframe = {"type": "object", "required": ["t"],
                "propertyNames": {"pattern": IDENT, "not": {"enum": ["v", "force", "device"]}},
                "additionalProperties": {"type": "number",
                                         "description": "another axis or button of the device, an output port"},
                "properties": {"t": {"type": "number", "minimum": 0, "description": "time [s]"},
                               "x": {"type": "number", "minimum": -1, "maximum": 1,
                                     "description": "hand position [m]"}}}
    common = {"driver": {"enum": DRIVERS, "default": "simulated"},
              "max_force": {**number, "exclusiveMinimum": 0, "maximum": 1000, "default": 4.0,
                            "description": "every force sent to the device is clamped to this [N]"}}
    simulated = {**common,
                 "mass": {**number, "exclusiveMinimum": 0, "maximum": 100, "default": 0.05,
                          "description": "moving mass of the device [kg]"},
                 "hand_stiffness": {**number, "minimum": 0, "maximum": 1e6, "default": 400.0,
                                    "description": "stiffness of the hand's grip [N/m]"},
                 "hand_damping": {**number, "minimum": 0, "maximum": 1e4, "default": 4.0,
                                  "description": "damping of the hand's grip [N·s/m]"},
                 "script": {"type": "array", "items": keyframe, "minItems": 1,
                            "description": "keyframes the hand follows, linear between them"},
                 "hold": {"type": "boolean", "default": True,
                          "description": "keep the last keyframe (true) or repeat the script (false)"}}
    usb_id = {"type": "integer", "minimum": 0, "maximum": 0xFFFF}
    hid = {**common,
           "profile": {"type": "string", "minLength": 1,
                       "description": "a shipped HID profile's name (gamepad, mouse, haptic_1dof) "
                                      "or a profile .yaml file beside the patch"},
           "vendor_id": {**usb_id, "description": "USB vendor id, if not the profile's"},
           "product_id": {**usb_id, "description": "USB product id, if not the profile's"},
           "serial": {"type": "string", "description": "open the device with this serial number"},
           "path": {"type": "string", "minLength": 1,
                    "description": "open the device at this hidapi path (`hapticgraph devices` lists them)"}}
    return {
        "type": "object",
        "properties": {"driver": common["driver"]},
        "allOf": [
            {"if": {"type": "object", "properties": {"driver": {"const": "simulated"}}},
             "then": {"properties": simulated, "additionalProperties": False}},
            {"if": {"required": ["driver"], "properties": {"driver": {"const": "hid"}}},
             "then": {"properties": hid, "required": ["profile"], "additionalProperties": False}},
            {"if": {"required": ["driver"], "properties": {"driver": {"const": "replay"}}},
             "then": {"properties": {**common, "file": {"type": "string"}}, "required": ["file"]}},
        ],
    }


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
    device = device_schema()
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
