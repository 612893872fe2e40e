"""blocks/ imports one way (issue 20): an import inside a function only for a heavy library, and
inside blocks/massspring/ each module imports only from the layers below it, in the order its
`__init__` lists them. (No cycle and no `_private` import across modules: tests/test_import_graph.py
for every package; the layers between packages: import-linter's contracts.)"""
import ast
import pathlib

import pytest

BLOCKS = pathlib.Path(__file__).resolve().parents[2] / "blocks"
PACKAGE = "hapticgraph.blocks"
HEAVY = {"numba", "scipy"}          # imported where they are used, never at start-up
MASSSPRING = [("steps", "stencils"), ("laws",), ("impact", "friction"), ("members",), ("arrays",), ("network",),
              ("checks",), ("family",), ("cells", "links")]


def _modules(root=BLOCKS, package=PACKAGE):
    """{dotted name: (path, is a package)} of every module under `root`."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        init = parts[-1] == "__init__"
        out[".".join([package] + (parts[:-1] if init else parts))] = (path, init)
    return out


def imports(root=BLOCKS, package=PACKAGE):
    """[(module, imported module, names, inside a function)] of every import statement."""
    modules, found = _modules(root, package), []
    for name, (path, init) in modules.items():
        base = name.split(".") if init else name.split(".")[:-1]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for fn in [tree] + [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]:
            nested = fn is not tree
            for node in ast.walk(fn) if nested else _outside_functions(tree):
                if isinstance(node, ast.Import):
                    found += [(name, a.name, (), nested) for a in node.names]
                elif isinstance(node, ast.ImportFrom):
                    if node.level:
                        parent = base[:len(base) - node.level + 1]
                        target = ".".join(parent + ([node.module] if node.module else []))
                    else:
                        target = node.module
                    names = tuple(a.name for a in node.names)
                    subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in modules]
                    if len(subs) == len(names):          # `from . import a, b`: the modules a and b
                        found += [(name, s, (), nested) for s in subs]
                    else:
                        found.append((name, target, names, nested))
    return found


def _outside_functions(tree):
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        yield node
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            todo.extend(ast.iter_child_nodes(node))


def test_the_measure_sees_an_import_in_a_function(tmp_path):
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("")
    (tmp_path / "pkg" / "a.py").write_text("from .b import x\n")
    (tmp_path / "pkg" / "b.py").write_text("def x():\n    from . import a\n    import numba\n")
    found = imports(tmp_path / "pkg", "pkg")
    assert ("pkg.a", "pkg.b", ("x",), False) in found
    assert ("pkg.b", "pkg.a", (), True) in found and ("pkg.b", "numba", (), True) in found


def test_imports_inside_functions_are_heavy_libraries_only():
    inside = [(a, b) for a, b, _, nested in imports() if nested and b.split(".")[0] not in HEAVY]
    assert inside == []


@pytest.mark.parametrize("module", [m for layer in MASSSPRING for m in layer])
def test_massspring_imports_only_from_below(module):
    rank = {m: i for i, layer in enumerate(MASSSPRING) for m in layer}
    prefix = f"{PACKAGE}.massspring."
    own = f"{prefix}{module}"
    targets = {b[len(prefix):].split(".")[0] for a, b, _, _ in imports() if a == own and b.startswith(prefix)}
    assert targets <= set(rank), targets - set(rank)
    assert [t for t in targets if rank[t] >= rank[module]] == []
