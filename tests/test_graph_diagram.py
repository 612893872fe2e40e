"""`hapticgraph graph`: every block a node, every connection and spring an edge, in dot and Mermaid."""
import shutil
import subprocess

import pytest

from project_env import PATCHES
from hapticgraph.cli import main
from hapticgraph.graph.diagram import to_dot, to_mermaid
from hapticgraph.graph.patch import load


@pytest.mark.parametrize("path", PATCHES, ids=[p.stem for p in PATCHES])
def test_every_block_and_connection_is_drawn(path):
    patch = load(path)
    dot, mermaid = to_dot(patch), to_mermaid(patch)
    for name in patch.blocks:
        assert f"  {name} [" in dot and f"  {name}" in mermaid
    assert dot.count(" -> ") >= len(patch.connections)
    assert mermaid.count("-->") == len(patch.connections)
    if shutil.which("dot"):
        subprocess.run(["dot", "-Tsvg"], input=dot, text=True, check=True, capture_output=True)


def test_cli_graph(patches_dir, tmp_path, capsys):
    assert main(["graph", str(patches_dir / "karplus_strong.yaml"), "--format", "mermaid"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("flowchart LR") and 'loop -->|"out → in"| damp' in out
    target = tmp_path / "g.dot"
    assert main(["graph", str(patches_dir / "karplus_strong.yaml"), "-o", str(target)]) == 0
    assert target.read_text().startswith("digraph")
