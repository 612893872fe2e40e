"""The documentation site builds with `mkdocs build --strict`: every page of the nav, every internal
link and anchor resolves (mkdocs.yml's `validation` makes each a warning, and --strict each
warning an error), the Python API reference finds every name, and nothing is fetched from the
internet. The block reference it shows is generated from the registry, as `hapticgraph blocks`
lists the block types."""
import importlib.util
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too
NEEDED = ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    missing = [m for m in NEEDED if importlib.util.find_spec(m.split(".")[0]) is None
               or importlib.util.find_spec(m) is None]
    if missing:
        pytest.fail(f"the documentation tools are not installed ({', '.join(missing)}): "
                    'python -m pip install -e ".[docs]"')
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}"
    warnings = [line for line in proc.stderr.splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert not warnings, "\n".join(warnings)
    return out


def _html(site, page):
    return (site / page).read_text(encoding="utf-8")


def test_every_page_of_the_nav_is_built(site):
    pages = [p.stem for p in (ROOT / "docs").glob("*.md")]
    for stem in pages:
        assert (site / stem / "index.html").is_file(), stem
    assert (site / "index.html").is_file() and (site / "benchmarks" / "index.html").is_file()
    assert (site / "security" / "index.html").is_file() and (site / "changelog" / "index.html").is_file()
    assert not (site / "hooks.py").exists()


def test_block_reference_lists_what_hapticgraph_blocks_lists(site):
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "blocks"], capture_output=True, text=True,
                          timeout=300, cwd=site)
    assert proc.returncode == 0, proc.stderr
    listed = re.findall(r"^(\w+): ", proc.stdout, re.M)
    shown = re.findall(r'<h2 id="(\w+)"', _html(site, "blocks/index.html"))
    assert len(listed) >= 30 and shown == sorted(listed)


def test_api_reference_documents_the_public_names(site):
    text = _html(site, "reference/index.html")
    for name in ("load", "check", "render", "sweep", "fit", "Session", "Patch", "Render", "PatchError",
                 "Problem", "PlanError", "SafetyStop", "DeviceError", "Block", "In", "Out", "Param", "State",
                 "Buffer", "helper", "register_feature"):
        assert re.search(rf'id="[\w.]*\b{name}"', text), name
    assert "process" in text and "Run the next" in text                  # a method's own docstring


def test_links_point_at_pages_of_the_site(site):
    """README's links to docs/*.md, benchmarks/ and SECURITY.md lead to pages of the site."""
    home = _html(site, "index.html")
    assert 'href="install/"' in home and 'href="benchmarks/"' in home and 'href="security/"' in home
    assert 'src="fig8.png"' in home


def test_nothing_is_fetched_from_the_internet(site):
    for page in site.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        fetched = re.findall(r'<(?:link|script|img)\b[^>]*(?:href|src)="(?:https?:)?//[^"]*"', text)
        assert not fetched, (page.relative_to(site), fetched)
        assert "hapticgraph-docs-" not in text, page       # the staged package's temporary folder


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_links_written_for_the_repository_are_pointed_at_the_site():
    hooks = _hooks()
    shown = {"README.md": "index.md", "SECURITY.md": "security.md", "benchmarks/README.md": "benchmarks/index.md",
             "benchmarks/realtime.md": "benchmarks/realtime.md"}
    home = hooks.point_links("[a](docs/install.md#editors) ![b](docs/fig8.png) [c](SECURITY.md) "
                             "[d](benchmarks/README.md#studio) [`e`](examples/file_plugin/) [f](docs/nope.md) "
                             "[g](https://example.org/x.md)\n```sh\n[h](docs/install.md)\n```\n", "index.md", shown)
    assert home.splitlines()[0] == ("[a](install.md#editors) ![b](fig8.png) [c](security.md) "
                                    "[d](benchmarks/index.md#studio) `e` [f](docs/nope.md) "
                                    "[g](https://example.org/x.md)")
    assert "[h](docs/install.md)" in home                         # code is left as it is
    page = hooks.point_links("[a](../SECURITY.md) [b](../benchmarks/realtime.md) [c](limits.md)", "live.md", shown)
    assert page == "[a](security.md) [b](benchmarks/realtime.md) [c](limits.md)"
    bench = hooks.point_links("[a](realtime.md) [b](../docs/architecture.md#start-up) [`c`](run_all.py)",
                              "benchmarks/index.md", shown)
    assert bench == "[a](realtime.md) [b](../architecture.md#start-up) `c`"


def test_the_package_is_staged_as_installed(tmp_path):
    _hooks().stage_package(tmp_path)
    for module in ("__init__.py", "session.py", "graph/engine.py", "blocks/vocabulary.py", "devices/errors.py",
                   "blocks/massspring/__init__.py", "cli/main.py", "sweeps/features.py"):
        assert (tmp_path / "hapticgraph" / module).is_file(), module
