"""The patterns of a patch's names, cell indices and connections, shared by the JSON Schema
(graph/schema.py), the voices section's (graph/voices.py) and the data model (graph/model.py)."""

# Patterns are ECMA-262 (for editors) and read by Python's re.search, whose `$` also matches
# before a final newline: `(?![\s\S])` anchors at the very end in both, so a name is matched whole.
END = r"(?![\s\S])"
IDENT = rf"^[A-Za-z_][A-Za-z0-9_]*{END}"
WHOLE = r"-?[0-9]{1,18}(\.0*)?"    # blocks.numbers.WHOLE_TEXT: 2 or 2.0, never 2.5
INDEX = rf"\[ *{WHOLE} *(, *{WHOLE} *)*\]"
ENDPOINT = rf"[A-Za-z_][A-Za-z0-9_]*({INDEX})?\.[A-Za-z_][A-Za-z0-9_]*"
CONNECTION = rf"^\s*{ENDPOINT}\s*->\s*{ENDPOINT}\s*{END}"
