"""What `mkdocs build` adds to the pages of docs/ (mkdocs.yml `hooks:`): plain Python, run at build
time, fetching nothing.

- The block reference (docs/blocks.md) is generated again from the registry's declarations, as
  `hapticgraph blocks --markdown` prints it, so the site never shows a stale one.
- Files that live outside docs/ become pages of the site as they are at build time: README.md
  (the home page), benchmarks/*.md and their pictures, SECURITY.md and CHANGELOG.md.
- Links are written for the repository, so that every page reads on a forge too
  (`../SECURITY.md`, `docs/install.md`); each one that names a file the site shows is pointed at
  that page, and one that names a file the site does not show (a script, an example folder)
  becomes its text. A link to a file that does not exist is left alone, for `--strict` to report.
- The Python API reference (mkdocstrings) reads the package's source laid out as it is installed:
  blocks/, graph/ and devices/ are mapped into `hapticgraph` by setuptools' `package-dir`, which
  static analysis of the repository's folders cannot see. The layout is copied into a temporary
  folder and handed to the handler as its `paths`.
"""
import posixpath
import re
import shutil
import tempfile
from pathlib import Path

try:
    import tomllib
except ImportError:             # Python 3.10
    import tomli as tomllib

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent

# files outside docs/ shown by the site: repository path -> site path
OUTSIDE = {"README.md": "index.md", "SECURITY.md": "security.md", "CHANGELOG.md": "changelog.md",
           "benchmarks/README.md": "benchmarks/index.md"}
OUTSIDE_GLOBS = ("benchmarks/*.md", "benchmarks/*.png")

LINK = re.compile(r"(!?)\[((?:[^\[\]]|\[[^\[\]]*\])*)\]\(([^()\s]+)((?:\s+\"[^\"]*\")?)\)")
FENCE = re.compile(r"^( *)(```|~~~).*?^\1\2[ \t]*$", re.S | re.M)
SCHEME = re.compile(r"[a-z][a-z0-9+.-]*:", re.I)


def outside_files():
    """{repository path: site path} of the files outside docs/ that the site shows."""
    out = {}
    for pattern in OUTSIDE_GLOBS:
        for path in sorted(ROOT.glob(pattern)):
            rel = path.relative_to(ROOT).as_posix()
            out[rel] = OUTSIDE.get(rel, rel)
    out.update({rel: site for rel, site in OUTSIDE.items() if (ROOT / rel).is_file()})
    return out


def _source(page_uri, shown):
    """The repository path a page of the site comes from."""
    for rel, site in shown.items():
        if site == page_uri:
            return rel
    return "docs/" + page_uri


def _site_path(rel, shown):
    if rel in shown:
        return shown[rel]
    if rel.startswith("docs/") and (ROOT / rel).exists():
        return rel[len("docs/"):]
    return None


def point_links(markdown, page_uri, shown=None):
    """The page's markdown with every relative link to a file of the repository pointed at the
    site's page for it, or turned into its text where the site does not show that file."""
    shown = outside_files() if shown is None else shown
    source = _source(page_uri, shown)

    def one(m):
        bang, text, target, title = m.groups()
        if SCHEME.match(target) or target.startswith(("#", "/")):
            return m.group(0)
        path, hash_, anchor = target.partition("#")
        rel = posixpath.normpath(posixpath.join(posixpath.dirname(source), path)).rstrip("/")
        site = _site_path(rel, shown)
        if site is None:
            if not (ROOT / rel).exists() or rel.startswith(".."):
                return m.group(0)              # a broken link: --strict says so
            return text                        # a file the site does not show: its name stays
        new = posixpath.relpath(site, posixpath.dirname(page_uri) or ".") + hash_ + anchor
        return f"{bang}[{text}]({new}{title})"

    parts, last = [], 0
    for fence in FENCE.finditer(markdown):
        parts.append(LINK.sub(one, markdown[last:fence.start()]))
        parts.append(fence.group(0))
        last = fence.end()
    parts.append(LINK.sub(one, markdown[last:]))
    return "".join(parts)


def block_reference_markdown():
    """The block reference as `hapticgraph blocks --markdown` prints it (built-in blocks)."""
    from hapticgraph.graph.registry import Registry
    from hapticgraph.reference import block_reference
    return block_reference(Registry(entry_points=False))


def stage_package(into):
    """Copy the package's modules into `into`, laid out as installed (pyproject's package-dir)."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    folders = setuptools.get("package-dir", {})
    for package in sorted(folders, key=lambda name: name.count(".")):
        source = ROOT / folders[package]
        for path in source.rglob("*.py"):
            if "__pycache__" in path.parts:
                continue
            target = Path(into, *package.split("."), path.relative_to(source))
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)


_staged = []


@event_priority(100)             # before mkdocstrings makes its handler, which reads `paths` then
def on_config(config):
    folder = tempfile.mkdtemp(prefix="hapticgraph-docs-")
    _staged.append(folder)
    stage_package(folder)
    plugin = config.plugins.get("mkdocstrings")
    if plugin is not None:
        python = plugin.config.handlers.setdefault("python", {})
        python["paths"] = [folder]
    return config


def on_files(files, config):
    for rel, site in outside_files().items():
        path = ROOT / rel
        if path.suffix == ".md":
            files.append(File.generated(config, site, content=path.read_text(encoding="utf-8")))
        else:
            files.append(File.generated(config, site, abs_src_path=str(path)))
    if not (ROOT / "CHANGELOG.md").is_file():
        files.append(File.generated(config, "changelog.md",
                                    content="# Changelog\n\nNo release has been described yet.\n"))
    return files


def on_page_markdown(markdown, page, config, files):
    if page.file.src_uri == "blocks.md":
        markdown = block_reference_markdown()
    return point_links(markdown, page.file.src_uri)


def on_shutdown():
    while _staged:
        shutil.rmtree(_staged.pop(), ignore_errors=True)


def on_post_build(config):
    on_shutdown()
