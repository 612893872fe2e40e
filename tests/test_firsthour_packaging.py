"""`pip install .` installs what the design names; `.[dev]` holds what the tests import."""
import ast
import importlib.metadata
import pathlib
import re
import sys
try:
    import tomllib
except ImportError:             # Python 3.10
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too


PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]


def _names(requirements):
    return {re.split(r"[<>=!~;\[ ]", r, maxsplit=1)[0].strip().lower().replace("_", "-") for r in requirements}


def test_core_dependencies_are_the_designs_packages():
    core = _names(PROJECT["dependencies"])
    for name in ("numpy", "scipy", "numba", "networkx", "pyyaml", "jsonschema",
                 "sounddevice", "hidapi", "soundfile", "tqdm"):
        assert name in core, name
    assert "matplotlib" not in core                                  # an extra: `hapticgraph[plot]`
    assert _names(PROJECT["optional-dependencies"]["plot"]) == {"matplotlib"}


def test_dev_extra_covers_every_third_party_import_of_the_tests():
    declared = _names(PROJECT["dependencies"]) | _names(PROJECT["optional-dependencies"]["dev"])
    local = {p.stem for p in (ROOT / "tests").rglob("*.py")} | {"hapticgraph", "hg_example_plugin"}
    by_module = importlib.metadata.packages_distributions()
    missing = {}
    for path in (ROOT / "tests").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                modules = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                modules = [node.module]
            else:
                continue
            for module in (m.split(".")[0] for m in modules):
                if module in sys.stdlib_module_names or module in local:
                    continue
                dists = {d.lower().replace("_", "-") for d in by_module.get(module, [module])}
                if not dists & declared:
                    missing.setdefault(module, path.name)
    assert not missing, f"imported by the tests but in neither dependencies nor [dev]: {missing}"
    assert "matplotlib" in declared                                   # `hapticgraph plot` is tested
