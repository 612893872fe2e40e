"""Run import-linter's `lint-imports` on this repository with the contracts of pyproject.toml.

The four packages live in four folders mapped into one namespace by setuptools' `package-dir`
(hapticgraph/, blocks/ -> hapticgraph.blocks, graph/ -> hapticgraph.graph, devices/ ->
hapticgraph.devices). import-linter's graph builder (grimp) reads a package from the folder of
its `__init__.py` and takes only top-level packages, so it would see hapticgraph/ alone. This
script copies the sources into a temporary folder laid out as the installed package is
(hapticgraph/blocks/, ...) and runs `lint-imports pyproject.toml` there; its exit status
is lint-imports'. Extra arguments go to lint-imports (`--verbose`, `--contract ID`).

    python tools/lint_imports.py
"""
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
FOLDERS = {"hapticgraph": ("hapticgraph",), "blocks": ("hapticgraph", "blocks"),
           "graph": ("hapticgraph", "graph"), "devices": ("hapticgraph", "devices")}


def stage(into, root=ROOT):
    """Copy every module of the four folders into `into`, laid out as the installed package."""
    for folder, parts in FOLDERS.items():
        for path in (root / folder).rglob("*.py"):
            target = pathlib.Path(into, *parts, path.relative_to(root / folder))
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)


def lint_imports():
    """The lint-imports beside this Python (a venv's bin/), else the one on PATH."""
    here = pathlib.Path(sysconfig.get_path("scripts"), "lint-imports")
    return str(here) if here.is_file() else shutil.which("lint-imports") or "lint-imports"


def main(argv=None):
    args = list(sys.argv[1:] if argv is None else argv)
    with tempfile.TemporaryDirectory(prefix="hapticgraph-lint-") as tmp:
        stage(tmp)
        env = dict(os.environ, PYTHONPATH=tmp)
        command = [lint_imports(), str(ROOT / "pyproject.toml"), "--no-cache"] + args
        return subprocess.run(command, cwd=tmp, env=env, check=False).returncode


if __name__ == "__main__":
    sys.exit(main())
