"""Every page is a test: each shell command, console session and Python block of the fenced code
of README.md and of every docs/*.md page is run as written, in a scratch folder holding copies of
`patches/` and `examples/` and the files the pages say to save, and what the text claims of its
results (a pitch, a force, a figure) is checked.

The cases are data: one test per command, in page order, named by its page and the command
itself, so a command that fails shows by name. What a fence's language means:
- `sh`: each line is a command, run (backslash continuations joined). Some are checked, not run:
  `pip install` (the extras it names must exist; the test environment is already installed),
  `pytest` and `python tests/...` (this suite runs them), `mkdocs` (tests/test_docs_site.py
  builds the site). Hardware steps (`play`, `devices`) pass when they work or stop cleanly for
  want of hardware: exit 1 or 2 with one line on standard error and no traceback.
- `console`: `$ COMMAND` then exactly what it prints (it exits 2: the examples are of errors).
- `python`: run in a fresh interpreter; docs/api.md's blocks are one session, run in order by
  tests/test_api_doc.py.
- `yaml`: "Save as `NAME`:" before it saves the file for the commands; "`patches/NAME`...:" before
  it means that patch, which it must equal (comments aside); every one must parse. `toml` parses.
- `bash`, `text` and a bare fence are shown, not run: a cluster, a browser, a synopsis.
"""
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
try:
    import tomllib
except ImportError:             # Python 3.10
    import tomli as tomllib

import numpy as np
import pytest
import soundfile
import yaml

from analysis import estimate_f0

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too
PAGES = ["README.md"] + [f"docs/{p.name}" for p in sorted((ROOT / "docs").glob("*.md"))]
OWN_RUNNER = {"docs/api.md": "tests/test_api_doc.py"}      # pages whose Python blocks run as one session
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def text_of(page):
    return (ROOT / page).read_text(encoding="utf-8")


def fenced(page):
    """[(language, text, the page's text just before the block)] in page order."""
    text = text_of(page)
    return [(m.group(1), m.group(2), " ".join(text[max(0, m.start() - 300):m.start()].split()))
            for m in FENCE.finditer(text)]


def saved_files():
    """{name: text} of the YAML blocks the pages say to save ("Save as `NAME`:")."""
    out = {}
    for page in PAGES:
        for lang, text, before in fenced(page):
            m = re.search(r"Save as `([^`]+)`:?$", before)
            if lang == "yaml" and m:
                assert out.get(m.group(1), text) == text, f"two pages save different {m.group(1)}"
                out[m.group(1)] = text
    return out


def commands():
    """[(page, command)] of every sh block's lines (backslash continuations joined)."""
    out = []
    for page in PAGES:
        for lang, text, _ in fenced(page):
            if lang == "sh":
                for line in text.replace("\\\n", " ").splitlines():
                    line = " ".join(line.split())
                    if line and not line.startswith("#"):
                        out.append((page, line))
    return out


def console():
    """[(page, command, expected output lines)] of the console blocks ("$ " lines)."""
    out = []
    for page in PAGES:
        for lang, text, _ in fenced(page):
            if lang == "console":
                lines = text.rstrip("\n").splitlines()
                assert lines[0].startswith("$ ")
                out.append((page, lines[0][2:], lines[1:]))
    return out


def python_blocks():
    return [(page, text) for page in PAGES if page not in OWN_RUNNER
            for lang, text, _ in fenced(page) if lang == "python"]


def make_workdir(work):
    """A scratch folder like a fresh clone's: the patches and examples (copied), an empty docs/,
    and the files the pages say to save. Nothing is written into the repository."""
    shutil.copytree(ROOT / "patches", work / "patches")
    shutil.copytree(ROOT / "examples", work / "examples")
    (work / "docs").mkdir()
    for name, text in saved_files().items():
        (work / name).write_text(text, encoding="utf-8")
    return work


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return make_workdir(tmp_path_factory.mktemp("docs"))


def _env():
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env.pop("HAPTICGRAPH_DEBUG", None)
    return env


def _sh(command, cwd, timeout=600):
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=_env(), capture_output=True, text=True,
                          timeout=timeout)


def _f0(path, start=0.3):
    audio, rate = soundfile.read(str(path), always_2d=True)
    return estimate_f0(audio[int(start * rate):, 0], rate)


# -- what each command claims, beyond "exit 0, no traceback" (matched by the command's start) ------
def _karplus(proc, work):
    assert _f0(work / "karplus_strong.wav", 0.2) == pytest.approx(441.0, rel=0.005)


def _tutorial_run(proc, work):
    assert _f0(work / "my_string.wav") == pytest.approx(44100 / 199, rel=0.005)       # 221.6 Hz
    force = np.load(work / "my_string.npz")["tip.force"]
    assert force.max() == pytest.approx(0.5, rel=0.01)                                # the release force


def _short_string(proc, work):
    assert _f0(work / "short.wav") == pytest.approx(44100 / 119, rel=0.005)            # 370.6 Hz


def _png(name):
    def check(proc, work):
        assert (work / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return check


def _mermaid(proc, work):
    assert proc.stdout.startswith("flowchart") and "tip" in proc.stdout and "-->" in proc.stdout


def _dot(proc, work):
    assert proc.stdout.lstrip().startswith("digraph") and "loop" in proc.stdout


def _lists_plugin(proc, work):
    assert "cubic.py" in proc.stdout + proc.stderr, "check does not name the plugin file it runs"


def _flac(proc, work):
    assert soundfile.info(str(work / "karplus_strong.flac")).format == "FLAC"


def _pcm16_quiet(proc, work):
    assert soundfile.info(str(work / "ks16.wav")).subtype == "PCM_16"
    assert "it/s" not in proc.stderr and "%|" not in proc.stderr                       # no progress bar


def _cell_force(proc, work):
    probes = np.load(work / "cymatic_string.npz")
    assert np.abs(probes["str[12].force"]).max() > 0.5 and np.abs(probes["str[50].velocity"]).max() > 0


def _babe_modes(proc, work):
    assert re.search(r"^\s+5\s+756\.37", proc.stdout, re.M), proc.stdout


def _babe_mode_plot(proc, work):
    assert "cym_a mode 5 at 756.37 Hz" in proc.stdout
    _png("docs/mode_cym_a.png")(proc, work)


def _schema(proc, work):
    assert json.loads((work / "hapticgraph.schema.json").read_text())["type"] == "object"


def _fig8(proc, work):   # the claim of the first set-up command
    audio, rate = soundfile.read(work / "fig8.wav")
    assert rate == 19000 and len(audio) == 2 * 19000
    plucked = np.abs(audio[int(0.04 * rate):int(0.8 * rate)]).max()
    damped = np.abs(audio[int(1.5 * rate):]).max()
    assert plucked > 0.05 and damped < plucked / 10      # the finger's rest damps the string


def _damped(proc, work):     # patches.md: more damping, a shorter ring than the patch's own
    audio, rate = soundfile.read(work / "damped.wav", always_2d=True)
    tail = np.abs(audio[int(0.4 * rate):]).max()
    assert 0 < tail < np.abs(audio).max() / 10


CLAIMS = {
    "hapticgraph run patches/fig8_pluck_damp.yaml --seconds 2 --out fig8.wav": _fig8,
    "hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav": _karplus,
    "hapticgraph run my_string.yaml --seconds 2 --probe tip.force": _tutorial_run,
    "hapticgraph run my_string.yaml --seconds 2 --set right_r.length=38": _short_string,
    "hapticgraph plot my_string.yaml": _png("string.png"),
    "hapticgraph graph my_string.yaml --format mermaid": _mermaid,
    "hapticgraph graph patches/karplus_strong.yaml --format dot": _dot,
    "hapticgraph check examples/file_plugin/saturated_string.yaml": _lists_plugin,
    "hapticgraph run patches/karplus_strong.yaml --seconds 1 --out karplus_strong.flac": _flac,
    "hapticgraph run patches/karplus_strong.yaml --seconds 1 --out ks16.wav": _pcm16_quiet,
    "hapticgraph run patches/cymatic_string.yaml --seconds 0.5 --probe": _cell_force,
    "hapticgraph run patches/cymatic_string.yaml --seconds 0.5 --set str.damping=0.01": _damped,
    "hapticgraph modes patches/babe_is_sleeping.yaml": _babe_modes,
    "hapticgraph plot patches/babe_is_sleeping.yaml": _babe_mode_plot,
    "hapticgraph plot patches/fig7_bowed_string.yaml": _png("docs/fig7.png"),
    "hapticgraph plot patches/fig8_pluck_damp.yaml": _png("docs/fig8.png"),
    "hapticgraph schema": _schema,
}
HARDWARE = ("hapticgraph play", "hapticgraph devices")
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
PROJECT_EXTRAS = PROJECT.get("optional-dependencies", {})


def _pip_install(command):
    """`pip install .`, `-e ".[dev]"`, `".[plot]"`: the project and the extras named must exist."""
    target = command.split("install", 1)[1].replace("-e", "").strip().strip("\"'")
    assert target.startswith("."), command
    for extra in re.findall(r"\[([^\]]+)\]", target)[:1]:
        for name in extra.split(","):
            assert name.strip() in PROJECT_EXTRAS, f"{command}: no extra {name!r} in pyproject.toml"


def _checked_not_run(command):
    """True for the commands this test checks without running them (see the module's doc)."""
    if command.startswith("python -m pytest -q"):
        dev = {re.split(r"[<>=;\s\[]", r)[0] for r in PROJECT_EXTRAS["dev"]}
        assert (ROOT / "tests").is_dir() and "pytest" in dev
        assert "-n" not in command.split() or "pytest-xdist" in dev        # -n is pytest-xdist's
        for path in re.findall(r"\btests/\S+\.py", command):
            assert (ROOT / path).is_file(), path
        return True
    m = re.match(r"python (tests/\S+\.py)", command)
    if m:
        assert (ROOT / m.group(1)).is_file(), m.group(1)
        return True
    if command.startswith("mkdocs "):
        assert (ROOT / "mkdocs.yml").is_file() and (ROOT / "tests" / "test_docs_site.py").is_file()
        return True
    return False


def test_pages_have_commands_to_run():
    runs = [c.partition(" && ")[2] if c.startswith("python -m pip install") else c for _, c in commands()]
    assert len(runs) >= 30 and len(python_blocks()) >= 3 and console()
    assert {"my_string.yaml", "bad.yaml", "timbre.yaml"} <= set(saved_files())
    unclaimed = [c for c in CLAIMS if not any(cmd.startswith(c) for cmd in runs)]
    assert not unclaimed, f"CLAIMS name commands no page has any more: {unclaimed}"


@pytest.mark.parametrize("page, command", commands(), ids=[f"{p}: {c}" for p, c in commands()])
def test_shell_command(page, command, workdir):
    if re.match(r"python -m pip install ", command):
        install, _, command = command.partition(" && ")
        _pip_install(install)
        if not command:
            return
    if _checked_not_run(command):
        return
    try:
        proc = _sh(command, workdir, timeout=120 if command.startswith(HARDWARE) else 600)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{command!r} did not finish (a hardware step should stop by itself without hardware)")
    assert "Traceback" not in proc.stderr, proc.stderr
    if command.startswith(HARDWARE) and proc.returncode in (1, 2):
        lines = [line for line in proc.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("hapticgraph:"), proc.stderr
        # stopped for want of hardware, not because the command line was misunderstood
        assert "expected NAME=DRIVER" not in lines[0] and "not available in this build" not in lines[0], lines[0]
        return
    assert proc.returncode == 0, f"{command}\nexit {proc.returncode}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    for start, claim in CLAIMS.items():
        if command.startswith(start):
            claim(proc, workdir)


@pytest.mark.parametrize("page, command, expected", console(), ids=[f"{p}: {c}" for p, c, _ in console()])
def test_console_output_is_what_the_page_shows(page, command, expected, workdir):
    proc = _sh(command, workdir)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert (proc.stdout + proc.stderr).splitlines() == expected


@pytest.mark.parametrize("page, snippet", python_blocks(),
                         ids=[f"{p}: {s.strip().splitlines()[0][:40]}" for p, s in python_blocks()])
def test_python_block(page, snippet, workdir):
    proc = subprocess.run([sys.executable, "-c", snippet], cwd=workdir, env=_env(), capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr


def test_shown_patch_is_the_file():
    """A YAML block introduced by "`patches/NAME`" is that patch (comments aside)."""
    shown = [(page, m.group(1), text) for page in PAGES for lang, text, before in fenced(page)
             for m in [re.search(r"`(patches/[^`]+)`[^`]*:$", before)] if lang == "yaml" and m]
    assert len(shown) >= 3
    for page, path, text in shown:
        assert yaml.safe_load((ROOT / path).read_text(encoding="utf-8")) == yaml.safe_load(text), (page, path)


def test_every_yaml_and_toml_block_parses():
    for page in PAGES:
        for lang, text, _ in fenced(page):
            if lang == "yaml":
                yaml.safe_load(text)
            elif lang == "toml":
                tomllib.loads(text)


def test_joystick_step_merges_into_the_tutorial_patch(workdir):
    """The tutorial's step 4 entries, added to my_string.yaml, check; headless (the pad on the
    simulated driver and the script the page gives) bridge.gain follows the stick from -0.95 to
    -0.999 and the string keeps its pitch."""
    fragment = next(yaml.safe_load(text) for lang, text, before in fenced("docs/tutorial.md")
                    if lang == "yaml" and "Add these entries to `my_string.yaml`" in before)
    patch = yaml.safe_load(saved_files()["my_string.yaml"])
    for key in ("devices", "blocks"):
        patch[key].update(fragment[key])
    patch["connect"] += fragment["connect"]
    (workdir / "pad_string.yaml").write_text(yaml.safe_dump(patch, sort_keys=False))
    proc = _sh("hapticgraph check pad_string.yaml", workdir)
    assert proc.returncode == 0, proc.stderr
    headless = re.search(r"`pad: (\{driver: simulated.*?\})`", text_of("docs/tutorial.md"), re.S).group(1)
    patch["devices"]["pad"] = yaml.safe_load(headless)
    (workdir / "pad_sim.yaml").write_text(yaml.safe_dump(patch, sort_keys=False))
    proc = _sh("hapticgraph run pad_sim.yaml --seconds 2 --probe hold.out --quiet", workdir)
    assert proc.returncode == 0, proc.stderr
    gain = np.load(workdir / "pad_sim.npz")["hold.out"]
    assert gain[0] == pytest.approx(-0.95, abs=1e-3) and gain[-1] == pytest.approx(-0.999, abs=1e-3)
    assert _f0(workdir / "pad_sim.wav") == pytest.approx(44100 / 199, rel=0.005)


@pytest.mark.parametrize("page", PAGES)
def test_links_name_files_of_the_repository(page):
    """Every relative link resolves from the page's folder (so pages read on a forge too), and
    every `patches/…`, `examples/…`, `docs/…` path the text names exists."""
    text = FENCE.sub("", text_of(page))
    base = (ROOT / page).parent
    targets = [t for t in re.findall(r"\]\(([^)#\s]+)", text) if not re.match(r"[a-z]+://", t)]
    missing = sorted({t for t in targets if not (base / t).exists()})
    named = [t for t in re.findall(r"`([^`\s]+)`", text)
             if re.match(r"(patches|examples|docs|benchmarks|tests|tools|\.ci)/", t) and "*" not in t]
    missing += sorted({t for t in named if not (ROOT / t).exists()})
    assert not missing, f"{page} names files that are not in the repository: {missing}"


@pytest.mark.parametrize("page", PAGES)
def test_figures_are_pictures(page):
    """Each picture a page shows is a PNG in the repository."""
    for target in re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text_of(page)):
        assert (ROOT / page).parent.joinpath(target).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", (page, target)


def test_pages_never_say_seed():
    for page in PAGES:
        found = re.findall(r".{0,30}\bseed\s*0\d\d.{0,30}", text_of(page), re.I)
        assert not found, (page, found)


def test_no_path_of_a_machine():
    """No page, nor the site's configuration, names a folder of the machine it was written on."""
    for page in PAGES + ["mkdocs.yml", "docs/hooks.py"]:
        found = re.findall(r".{0,30}(?:/tmp/|/work/|/root/|/home/\w).{0,30}", text_of(page))
        assert not found, (page, found)
