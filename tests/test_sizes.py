"""Lazy and small (issue 12, item 7; blocks/ since issue 20): no module over 400 lines and no
function over 50 lines in blocks/, graph/, devices/ and hapticgraph/, measured by tools/sizes.py,
which `python tools/sizes.py` runs by hand."""
import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
FOLDERS = ("blocks", "graph", "devices", "hapticgraph")


def _sizes():
    spec = importlib.util.spec_from_file_location("hg_tools_sizes", ROOT / "tools" / "sizes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_no_module_over_400_lines_and_no_function_over_50():
    sizes = _sizes()
    assert (sizes.MAX_MODULE, sizes.MAX_FUNCTION) == (400, 50)
    big_modules, big_functions = sizes.over_limits(FOLDERS, ROOT)
    assert big_modules == [], big_modules
    assert big_functions == [], big_functions


def test_the_measure_sees_what_is_too_long(tmp_path):
    """The measure is not vacuous: it reports a long module and a long method, nested or not."""
    sizes = _sizes()
    (tmp_path / "pkg").mkdir()
    body = "".join(f"    x{i} = {i}\n" for i in range(60))
    (tmp_path / "pkg" / "big.py").write_text(
        f"class A:\n    def long(self):\n{body.replace('    ', '        ')}\n\ndef short():\n    return 1\n"
        + "\n" * 400)
    big_modules, big_functions = sizes.over_limits(("pkg",), tmp_path)
    assert [rel for rel, _ in big_modules] == ["pkg/big.py"]
    assert [(where, n) for where, n in big_functions] == [("pkg/big.py:2 A.long", 61)]
