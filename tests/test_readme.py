"""Every README command is a test: each shell command and each Python snippet of the README's
fenced blocks is run as written, in a scratch folder holding copies of `patches/` and `examples/`
and the files the README says to save, and the figures its text claims are checked.

The cases are data: one test per command, in README order, named by the command itself, so a
README command that fails shows by name. Two commands are checked, not run: `pip install` (the
extras it names must exist; the test environment is already installed) and `pytest` (this is it).
Hardware steps (`play`, `devices`) pass when they work or stop cleanly for want of hardware:
exit 1 or 2 with one line on standard error and no traceback.
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
import soundfile
import pytest
import soundfile
import yaml

from analysis import estimate_f0

ROOT = pathlib.Path(__file__).resolve().parent.parent    # not `from conftest`: tests/hostile has one too

README = (ROOT / "README.md").read_text(encoding="utf-8")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def _fenced():
    """[(language, text, the README text just before the block)] in README order."""
    return [(m.group(1), m.group(2), " ".join(README[max(0, m.start() - 300):m.start()].split()))
            for m in FENCE.finditer(README)]


def _saved_files():
    """{name: text} of the YAML blocks the README says to save ("Save as `NAME`:")."""
    out = {}
    for lang, text, before in _fenced():
        m = re.search(r"Save as `([^`]+)`:?$", before)
        if lang == "yaml" and m:
            out[m.group(1)] = text
    return out


def _commands():
    """Every shell command of the README's sh blocks (backslash continuations joined)."""
    out = []
    for lang, text, _ in _fenced():
        if lang == "sh":
            for line in text.replace("\\\n", " ").splitlines():
                line = " ".join(line.split())
                if line and not line.startswith("#"):
                    out.append(line)
    return out


def _console():
    """(command, expected output lines) of the README's console blocks ("$ " lines)."""
    out = []
    for lang, text, _ in _fenced():
        if lang == "console":
            lines = text.rstrip("\n").splitlines()
            assert lines[0].startswith("$ ")
            out.append((lines[0][2:], lines[1:]))
    return out


def _python_snippets():
    return [text for lang, text, _ in _fenced() if lang == "python"]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A scratch folder like a fresh clone's: the patches and examples (copied), an empty docs/,
    and the files the README says to save. Nothing is written into the repository."""
    work = tmp_path_factory.mktemp("readme")
    shutil.copytree(ROOT / "patches", work / "patches")
    shutil.copytree(ROOT / "examples", work / "examples")
    (work / "docs").mkdir()
    for name, text in _saved_files().items():
        (work / name).write_text(text, encoding="utf-8")
    return work


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


CLAIMS = {
    "hapticgraph run patches/fig8_pluck_damp.yaml --seconds 2 --out fig8.wav": _fig8,
    "hapticgraph run patches/karplus_strong.yaml --seconds 2 --out karplus_strong.wav": _karplus,
    "hapticgraph run my_string.yaml --seconds 2 --probe tip.force": _tutorial_run,
    "hapticgraph run my_string.yaml --seconds 2 --set right_r.length=38": _short_string,
    "hapticgraph plot my_string.yaml": _png("string.png"),
    "hapticgraph graph my_string.yaml --format mermaid": _mermaid,
    "hapticgraph check examples/file_plugin/saturated_string.yaml": _lists_plugin,
    "hapticgraph run patches/karplus_strong.yaml --seconds 1 --out karplus_strong.flac": _flac,
    "hapticgraph run patches/karplus_strong.yaml --seconds 1 --out ks16.wav": _pcm16_quiet,
    "hapticgraph run patches/cymatic_string.yaml": _cell_force,
    "hapticgraph modes patches/babe_is_sleeping.yaml": _babe_modes,
    "hapticgraph plot patches/babe_is_sleeping.yaml": _babe_mode_plot,
    "hapticgraph plot patches/fig7_bowed_string.yaml": _png("docs/fig7.png"),
    "hapticgraph plot patches/fig8_pluck_damp.yaml": _png("docs/fig8.png"),
    "hapticgraph schema": _schema,
}
HARDWARE = ("hapticgraph play", "hapticgraph devices")


def _pip_install(command):
    """`pip install .`, `-e ".[dev]"`, `".[plot]"`: the project and the extras named must exist."""
    extras = PROJECT_EXTRAS
    target = command.split("install", 1)[1].replace("-e", "").strip().strip("\"'")
    assert target.startswith("."), command
    for extra in re.findall(r"\[([^\]]+)\]", target)[:1]:
        for name in extra.split(","):
            assert name.strip() in extras, f"{command}: no extra {name!r} in pyproject.toml"


PROJECT_EXTRAS = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"][
    "optional-dependencies"]


def test_readme_has_commands_to_run():
    commands = _commands()
    assert len(commands) >= 15 and len(_python_snippets()) >= 2 and _console()
    assert {"my_string.yaml", "bad.yaml"} <= set(_saved_files())
    unclaimed = [c for c in CLAIMS if not any(c in cmd for cmd in commands)]
    assert not unclaimed, f"CLAIMS name commands the README no longer has: {unclaimed}"


@pytest.mark.parametrize("command", _commands())
def test_shell_command(command, workdir):
    if re.match(r"python -m pip install ", command):
        install, _, command = command.partition(" && ")
        _pip_install(install)
        if not command:
            return
    if command.startswith("python -m pytest -q"):
        dev = {re.split(r"[<>=;\s]", r)[0] for r in PROJECT_EXTRAS["dev"]}
        assert (ROOT / "tests").is_dir() and "pytest" in dev
        assert "-n" not in command.split() or "pytest-xdist" in dev        # -n is pytest-xdist's
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


@pytest.mark.parametrize("command, expected", _console())
def test_console_output_is_what_the_readme_shows(command, expected, workdir):
    proc = _sh(command, workdir)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert (proc.stdout + proc.stderr).splitlines() == expected


@pytest.mark.parametrize("snippet", _python_snippets(), ids=lambda s: s.strip().splitlines()[0][:40])
def test_python_snippet(snippet, workdir):
    proc = subprocess.run([sys.executable, "-c", snippet], cwd=workdir, env=_env(), capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    if "hapticgraph.check(" in snippet:          # the Python API section: what its comments claim
        lines = proc.stdout.splitlines()
        assert lines[0] == "[]" and lines[1] == "44100.0 (44100, 2) (44100,)", proc.stdout
        assert lines[2].startswith("4 ") and "dealy" in lines[2]                # bad.yaml's problems
        assert "probe 'loop.nope'" in proc.stdout


def test_shown_patch_is_the_file(workdir):
    """A YAML block introduced by "`patches/NAME`" is that patch (comments aside)."""
    shown = [(m.group(1), text) for lang, text, before in _fenced()
             for m in [re.search(r"`(patches/[^`]+)`[^`]*:$", before)] if lang == "yaml" and m]
    assert shown
    for path, text in shown:
        assert yaml.safe_load((ROOT / path).read_text(encoding="utf-8")) == yaml.safe_load(text), path


def test_joystick_step_merges_into_the_tutorial_patch(workdir):
    """Step 4's entries, added to my_string.yaml, check; headless (the pad on the simulated driver
    and the script the README gives) bridge.gain follows the stick from -0.95 to -0.999 and the
    string keeps its pitch."""
    fragment = next(yaml.safe_load(text) for lang, text, before in _fenced()
                    if lang == "yaml" and "Add these entries to `my_string.yaml`" in before)
    patch = yaml.safe_load(_saved_files()["my_string.yaml"])
    for key in ("devices", "blocks"):
        patch[key].update(fragment[key])
    patch["connect"] += fragment["connect"]
    (workdir / "pad_string.yaml").write_text(yaml.safe_dump(patch, sort_keys=False))
    proc = _sh("hapticgraph check pad_string.yaml", workdir)
    assert proc.returncode == 0, proc.stderr
    headless = re.search(r"`pad: (\{driver: simulated.*?\})`", README, re.S).group(1)
    patch["devices"]["pad"] = yaml.safe_load(headless)
    (workdir / "pad_sim.yaml").write_text(yaml.safe_dump(patch, sort_keys=False))
    proc = _sh("hapticgraph run pad_sim.yaml --seconds 2 --probe hold.out --quiet", workdir)
    assert proc.returncode == 0, proc.stderr
    gain = np.load(workdir / "pad_sim.npz")["hold.out"]
    assert gain[0] == pytest.approx(-0.95, abs=1e-3) and gain[-1] == pytest.approx(-0.999, abs=1e-3)
    assert _f0(workdir / "pad_sim.wav") == pytest.approx(44100 / 199, rel=0.005)


def test_links_name_files_of_the_repository():
    targets = [t for t in re.findall(r"\]\(([^)#\s]+)\)", README) if not re.match(r"[a-z]+://", t)]  # web links aside
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
