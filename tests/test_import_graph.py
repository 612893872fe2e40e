"""The house (issue 20, item 1): the static import graph of the four packages, every import
statement counted (those inside functions too), has no cycle, and no module takes a `_private`
name from another. Measured by tools/imports.py (`python tools/imports.py` tells the same by
hand); import-linter's contracts in pyproject.toml say it again in CI (tools/lint_imports.py)."""
import importlib.util
import pathlib

import pytest

try:
    import tomllib
except ImportError:         # Python 3.10
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("hapticgraph", "hapticgraph.blocks", "hapticgraph.graph", "hapticgraph.devices")


def _imports():
    spec = importlib.util.spec_from_file_location("hg_tools_imports", ROOT / "tools" / "imports.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def report():
    return _imports().report()


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle(report, package):
    assert report[package]["cycles"] == [], f"{package}: import cycles {report[package]['cycles']}"


@pytest.mark.parametrize("package", PACKAGES)
def test_no_private_name_imported_from_another_module(report, package):
    found = [f"{importer}:{line} takes {module}.{name}" for importer, line, module, name in report[package]["private"]]
    assert found == [], found


def test_the_measure_sees_cycles_inside_functions_and_private_imports(tmp_path):
    """The measure is not vacuous: a cycle closed by an import inside a function, a private name
    taken with `from`, one read as a module's attribute; an alias is the importer's own name."""
    imports = _imports()
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .b import helper, _secret\n\n\ndef f():\n    return helper() + _secret\n")
    (pkg / "b.py").write_text("from .c import value as _value\n\n\ndef helper():\n    from . import a\n"
                              "    return a.f\n\n\n_secret = 1\n")
    (pkg / "c.py").write_text("from . import b\n\nvalue = 2\n\n\ndef g():\n    return b._secret\n")
    found = imports.report(tmp_path, {"pkg": "pkg"})["pkg"]
    assert found["cycles"] == [["pkg.a", "pkg.b", "pkg.c"]]
    assert sorted((importer, module, name) for importer, _, module, name in found["private"]) == [
        ("pkg.a", "pkg.b", "_secret"), ("pkg.c", "pkg.b", "_secret")]


def test_import_linter_has_the_contracts():
    """CI runs import-linter with these contracts (a layers one, an acyclic one over every package)."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert any(r.startswith("import-linter") for r in config["project"]["optional-dependencies"]["dev"])
    contracts = {c["type"]: c for c in config["tool"]["importlinter"]["contracts"]}
    layers = contracts["layers"]["layers"]
    assert layers[-4:] == ["session", "devices", "graph", "blocks"]
    assert layers.index("cli") < next(i for i, layer in enumerate(layers) if "studio" in layer and "sweeps" in layer)
    assert contracts["acyclic_siblings"]["ancestors"] == ["hapticgraph"]
    door = contracts["forbidden"]
    assert set(door["source_modules"]) == {"hapticgraph.studio", "hapticgraph.sweeps"}
    assert door["forbidden_modules"] == ["hapticgraph.graph.engine"]
    assert "tools/lint_imports.py" in (ROOT / ".ci" / "run").read_text(encoding="utf-8")
