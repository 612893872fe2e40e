"""The README is the front door: what hapticgraph is, the two set-up commands (the ones .ci/run
runs), a first patch, a picture and links into the documentation, in at most about 200 lines.
Its commands and code blocks are run with every page's by tests/test_docs_pages.py."""
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too
README = (ROOT / "README.md").read_text(encoding="utf-8")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def _sh_lines(text):
    return [" ".join(line.split()) for lang, block in FENCE.findall(text) if lang == "sh"
            for line in block.replace("\\\n", " ").splitlines() if line.strip() and not line.startswith("#")]


def test_is_short():
    assert len(README.splitlines()) <= 200


def test_set_up_commands_are_the_ones_ci_runs():
    """The README's first two commands are .ci/run's "README command 1" and "2", up to CI's
    quiet flags and its scratch output folder."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ran = []
    for n in (1, 2):
        block = ci.split(f"# README command {n}", 1)[1].split("\n", 1)[1]
        line = block.splitlines()[0]
        line = line.replace("pip install -q ", "pip install ").replace('"$out/', "").replace('.wav"', ".wav")
        ran.append(line.replace(" --quiet", ""))
    assert _sh_lines(README)[:2] == ran


def test_shows_a_first_patch_and_a_picture():
    assert "```yaml\nhapticgraph: 1" in README
    pictures = re.findall(r"!\[[^\]]+\]\((docs/[^)\s]+\.png)\)", README)
    assert pictures and all((ROOT / p).is_file() for p in pictures)


def test_links_into_every_page_of_the_site():
    linked = {pathlib.PurePosixPath(t).name for t in re.findall(r"\]\(docs/([^)#\s]+\.md)", README)}
    pages = {p.name for p in (ROOT / "docs").glob("*.md")}
    assert pages <= linked, f"the README links to no {sorted(pages - linked)}"
    assert "mkdocs serve" in README and '".[docs]"' in README


def test_links_name_files_of_the_repository():
    targets = [t for t in re.findall(r"\]\(([^)#\s]+)\)", README) if not re.match(r"[a-z]+://", t)]
    targets += [t for t in re.findall(r"`([^`\s]+)`", README)
                if re.match(r"(patches|examples|docs|benchmarks|tests|\.ci)/", t) and "*" not in t]
    assert targets
    missing = sorted({t for t in targets if not (ROOT / t).exists()})
    assert not missing, f"the README names files that are not in the repository: {missing}"


def test_cites_the_papers_and_never_says_seed():
    text = " ".join(README.split())
    for part in ("Edgar Berdahl, Günter Niemeyer and Julius O. Smith III",
                 "Using Haptic Devices to Interface Directly with Digital Waveguide-Based Musical Instruments",
                 "NIME 2009", "David M. Howard and Stuart M. Rimell",
                 "Cymatic: a Tactile Controlled Physical Modelling Instrument", "DAFx-03"):
        assert part in text, part
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        found = re.findall(r".{0,30}\bseed\s*0\d\d.{0,30}", path.read_text(encoding="utf-8"), re.I)
        assert not found, (path.name, found)
