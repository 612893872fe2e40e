"""docs/blocks.md is generated from the block declarations and must be current."""
from project_env import ROOT
from hapticgraph.graph.registry import Registry
from hapticgraph.reference import block_reference


def test_block_reference_is_current():
    expected = block_reference(Registry(entry_points=False))
    actual = (ROOT / "docs" / "blocks.md").read_text(encoding="utf-8")
    assert actual == expected, "docs/blocks.md is stale: run `hapticgraph blocks --markdown > docs/blocks.md`"


def test_reference_covers_every_block_and_parameter():
    registry = Registry(entry_points=False)
    text = block_reference(registry)
    for name, cls in registry.types.items():
        assert f"## {name}\n" in text
        for pname, p in cls.params.items():
            if not p.internal:
                assert f"| `{pname}` |" in text
