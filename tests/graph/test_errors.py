"""Patch errors beyond the corpus: all at once, overrides, alias bombs and huge files in real
processes, exit codes. `FILE:LINE: message` naming the block or port, exit 2, no traceback."""
import os
import subprocess
import sys
import time


from hapticgraph.cli import main

OK_HEAD = "hapticgraph: 1\nrate: 44100\n"

# Every kind of error has a patch in tests/corpus/ (tests/test_corpus.py); here: what a single
# corpus file cannot show (several problems at once, overrides, real processes, sizes).


def test_all_problems_reported_at_once(tmp_path, capsys):
    path = tmp_path / "many.yaml"
    path.write_text(OK_HEAD + "blocks:\n  a: {type: dealy}\n  b: {type: gain, gain: x}\n"
                    "  c: {type: gain}\nconnect:\n  - c.out -> c.in\n  - c.out -> zz.in\n")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    for needle in ("unknown type 'dealy'", "'x' is not a number", "algebraic loop", "no block named 'zz'"):
        assert needle in err


def test_override_errors(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text(OK_HEAD + "blocks:\n  a: {type: delay, length: 3}\n")
    assert main(["check", str(path), "--set", "a.length=0"]) == 2
    assert "a' (delay): parameter 'length': 0 is below the minimum" in capsys.readouterr().err
    assert main(["check", str(path), "--set", "zz.length=4"]) == 2
    assert "no block named 'zz'" in capsys.readouterr().err
    assert main(["check", str(path), "--set", "a.length=4"]) == 0


def _timed_check(path):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "check", str(path)],
                          capture_output=True, text=True, timeout=60)
    return proc, time.perf_counter() - start


def test_alias_bomb_fails_fast(tmp_path):
    lol = ", ".join(['"lol"'] * 9)
    text = OK_HEAD + f"a: &a [{lol}]\n"
    prev = "a"
    for i in range(9):
        name = f"l{i}"
        text += f"{name}: &{name} [" + ", ".join([f"*{prev}"] * 9) + "]\n"
        prev = name
    path = tmp_path / "bomb.yaml"
    path.write_text(text)
    proc, seconds = _timed_check(path)
    assert proc.returncode == 2 and "alias bomb" in proc.stderr and "Traceback" not in proc.stderr
    assert seconds < 10   # generous for a cold interpreter; the parse itself takes ~0.1 s


def test_huge_file_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.yaml"
    with open(path, "w") as f:
        f.write(OK_HEAD + "blocks:\n")
        chunk = "".join(f"  b{i}: {{type: gain}}\n" for i in range(10000))
        while f.tell() < 100 * 1024 * 1024:
            f.write(chunk)
    proc, seconds = _timed_check(path)
    assert proc.returncode == 2 and ":1: file is" in proc.stderr and "at most 4 MB" in proc.stderr
    assert seconds < 10


def test_missing_file(tmp_path, capsys):
    assert main(["check", str(tmp_path / "absent.yaml")]) == 2
    assert "cannot read the patch" in capsys.readouterr().err


def test_cli_exit_codes_in_a_real_process(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(OK_HEAD + "blocks:\n  a: {type: gain, gain: x}\n")
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "run", str(bad), "--out", str(tmp_path / "o.wav")],
                          capture_output=True, text=True, timeout=120, env={**os.environ})
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"{bad}:4: block 'a' (gain)")
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "o.wav").exists()


def test_bad_probe_is_a_usage_error(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text(OK_HEAD + "blocks:\n  a: {type: constant}\n")
    assert main(["run", str(path), "--probe", "a.nothing", "--out", str(tmp_path / "x.wav")]) == 2
    assert "probe 'a.nothing'" in capsys.readouterr().err


def test_the_collector_keeps_a_bounded_number_of_problems():
    from hapticgraph.graph.errors import Collector, PatchError
    problems = Collector("p.yaml", limit=3)
    for line in range(1, 11):
        problems.add(line, f"problem {line}")
    assert problems.full and len(problems.problems) == 3 and problems.suppressed == 7
    try:
        problems.raise_if_any()
    except PatchError as exc:
        lines = [str(p) for p in exc.problems]
    assert lines == ["p.yaml:1: problem 1", "p.yaml:2: problem 2", "p.yaml:3: problem 3",
                     "p.yaml:4: 7 more problem(s) not shown (at most 3 are reported)"]


def test_set_values_are_read_like_the_file(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text(OK_HEAD + "blocks:\n  f: {type: lowpass}\n")
    assert main(["check", str(path), "--set", "f.coeffs=[0.5, 0.5]", "--set", "f.gain=0.5"]) == 0
    assert main(["check", str(path), "--set", "f.gain=.inf"]) == 2
    assert f"{path}:4: --set 'f.gain=.inf': '.inf': numbers must be finite" in capsys.readouterr().err


# -- devices: graph/ knows no driver; the caller hands the loader the driver kinds -------------------

DEVICE_PATCH = OK_HEAD + ("devices:\n  finger: {driver: simulated, script: [{t: 0.0, x: 0.0, button: 1}]}\n"
                          "  thumb: {max_force: 1.0}\nblocks:\n  h: {type: haptic, device: finger}\n"
                          "  k: {type: haptic, device: thumb}\n")


def _problems(path, **kw):
    from hapticgraph.graph.errors import PatchError
    from hapticgraph.graph.patch import load
    try:
        load(path, **kw)
    except PatchError as exc:
        return [(p.line, p.message) for p in exc.problems]
    return []


def test_a_patch_loaded_without_drivers_names_its_devices_drivers_unknown(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(DEVICE_PATCH)
    problems = _problems(path, drivers=())
    assert (4, "device 'finger': unknown driver 'simulated'; the drivers are: none (the loader was "
               "given no driver table)") in problems
    assert (5, "device 'thumb': no driver given, and there is no default one; the drivers are: none "
               "(the loader was given no driver table)") in problems


def test_the_default_drivers_are_the_devices_packages(tmp_path):
    from hapticgraph.devices.table import driver_kinds
    from hapticgraph.graph.patch import load
    path = tmp_path / "p.yaml"
    path.write_text(DEVICE_PATCH)
    patch = load(path)
    assert set(patch.registry.drivers) == set(driver_kinds())
    assert [p.name for p in patch.blocks["h"].outputs] == ["x", "v", "button"]   # the simulated kind's axes
    assert load(path, drivers=driver_kinds()).blocks["h"].values["axes"] == ["button"]


def test_an_unknown_driver_is_reported_once_with_a_suggestion(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text(OK_HEAD + "devices:\n  finger: {driver: simulatd}\nblocks:\n  h: {type: haptic, device: finger}\n")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{path}:4: device 'finger': unknown driver 'simulatd' (did you mean 'simulated'?); "
                   "the drivers are: evdev, hid, midi, osc, replay, serial, simulated"]


def test_graph_imports_nothing_from_devices():
    import ast
    import pathlib
    graph = pathlib.Path(__file__).resolve().parents[2] / "graph"
    for path in sorted(graph.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""] + [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            assert not any("devices" in n for n in names), f"{path.name}:{node.lineno} imports devices/"
