"""Issue "One IR", item 2: graph/ names no block type and no port as a string (tools/literals.py);
the one port name left is graph's own block declaration (the feed of a plugin block compiled on
its own, graph/isolate.py)."""
import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_graph_has_no_block_type_or_port_literals():
    spec = importlib.util.spec_from_file_location("hg_tools_literals", ROOT / "tools" / "literals.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    found = module.hits([ROOT / "graph"])
    # isolate.py declares graph's own block (its port 'out'); voices.py's 'v' is the prefix of a
    # voice's copies (v1_str), which only happens to spell a port name
    assert sorted((pathlib.Path(p).name, text) for p, _, text in found) == [("isolate.py", "out"), ("voices.py", "v")], found
    # the measure is not vacuous: blocks/ declares ports by these names
    assert len(module.hits([ROOT / "blocks"])) > 10
