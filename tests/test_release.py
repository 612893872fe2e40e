"""What a packager gets: `python -m build` makes an sdist and a wheel whose contents are what
pyproject.toml and MANIFEST.in promise. The wheel holds the package with every data file a command
reads (the studio's page and its vendored libraries, the device profiles) and the licenses (PEP
639); neither holds tests/data (third-party test files under their own licenses); the version is
hapticgraph.__version__, the one source, and `hapticgraph --version` prints it."""
import shutil
import subprocess
import sys
import tarfile
import zipfile

import pytest

import hapticgraph
from project_env import ROOT

# package folder in the wheel -> its folder in the repository (pyproject's package-dir)
DATA = {"hapticgraph/studio/static": ROOT / "hapticgraph" / "studio" / "static",
        "hapticgraph/devices/profiles": ROOT / "devices" / "profiles"}


@pytest.fixture(scope="module")
def dists(tmp_path_factory):
    base = tmp_path_factory.mktemp("release")
    source = base / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".hypothesis", ".pytest_cache",
        ".import_linter_cache", "site"))
    out = base / "dist"
    proc = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(source)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    wheel, = out.glob("*.whl")
    sdist, = out.glob("*.tar.gz")
    with zipfile.ZipFile(wheel) as z:
        wheel_names = z.namelist()
        metadata = z.read(next(n for n in wheel_names if n.endswith(".dist-info/METADATA"))).decode()
    with tarfile.open(sdist) as t:
        sdist_names = [n.split("/", 1)[1] for n in t.getnames() if "/" in n]
    return wheel, wheel_names, metadata, sdist_names


def test_the_version_has_one_source(dists, capsys):
    wheel, _, metadata, _ = dists
    assert f"hapticgraph-{hapticgraph.__version__}-" in wheel.name
    assert f"\nVersion: {hapticgraph.__version__}\n" in metadata
    from hapticgraph.cli import main
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"hapticgraph {hapticgraph.__version__}"


def test_the_wheel_carries_the_licenses(dists):
    _, names, metadata, _ = dists
    assert "\nLicense-Expression: MIT\n" in metadata
    licenses = {n.split(".dist-info/licenses/", 1)[1] for n in names if ".dist-info/licenses/" in n}
    assert {"LICENSE", "THIRD_PARTY.md", "hapticgraph/studio/static/vendor/three/LICENSE",
            "hapticgraph/studio/static/vendor/uplot/LICENSE"} <= licenses
    # and beside the vendored code itself
    assert "hapticgraph/studio/static/vendor/three/LICENSE" in names


def test_the_wheel_has_every_data_file_a_command_reads(dists):
    _, names, _, _ = dists
    missing = [f"{package}/{path.relative_to(folder).as_posix()}" for package, folder in DATA.items()
               for path in folder.rglob("*") if path.is_file() and "__pycache__" not in path.parts
               and f"{package}/{path.relative_to(folder).as_posix()}" not in names]
    assert missing == []
    # every module of the four folders (a subpackage left out of pyproject's list is not shipped)
    folders = {"hapticgraph": ROOT / "hapticgraph", "hapticgraph/blocks": ROOT / "blocks",
               "hapticgraph/graph": ROOT / "graph", "hapticgraph/devices": ROOT / "devices"}
    modules = [f"{package}/{path.relative_to(folder).as_posix()}" for package, folder in folders.items()
               for path in folder.rglob("*.py") if "__pycache__" not in path.parts]
    assert [m for m in modules if m not in names] == []
    for package in ("cli", "sweeps", "studio", "export", "blocks", "blocks/massspring", "graph", "graph/c", "devices"):
        assert f"hapticgraph/{package}/__init__.py" in names, package


def test_neither_holds_the_tests_third_party_data(dists):
    _, wheel_names, _, sdist_names = dists
    assert not [n for n in wheel_names if n.startswith(("tests/", "benchmarks/", "patches/"))]
    assert not [n for n in sdist_names if n.startswith("tests/data")]
    assert "tests/data/midi/LICENSE.GPL-2" in {p.relative_to(ROOT).as_posix() for p in (ROOT / "tests" / "data").rglob("*")}
    for name in ("LICENSE", "THIRD_PARTY.md", "CHANGELOG.md", "README.md", "pyproject.toml", "MANIFEST.in"):
        assert name in sdist_names, name
    assert "tests/test_release.py" in sdist_names and "patches/fig8_pluck_damp.yaml" in sdist_names
