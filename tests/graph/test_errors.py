"""Every kind of patch error: `FILE:LINE: message` naming the block or port, exit 2, no traceback."""
import os
import re
import subprocess
import sys
import time

import pytest

from hapticgraph.cli import main

OK_HEAD = "hapticgraph: 1\nrate: 44100\n"

CASES = [
    # (id, text, line, substring)
    ("yaml-syntax", OK_HEAD + "blocks:\n  a: {type: gain\nconnect: []\n", 5, "YAML syntax"),
    ("empty", "", 1, "empty"),
    ("not-a-mapping", "- 1\n- 2\n", 1, "a patch is a mapping"),
    ("no-version", "rate: 44100\nblocks: {}\n", 1, "hapticgraph: 1"),
    ("bad-version", "hapticgraph: 2\nblocks: {}\n", 1, "unsupported patch format version 2"),
    ("duplicate-key", OK_HEAD + "blocks:\n  a: {type: gain}\n  a: {type: gain}\n", 5, "duplicate key 'a' (first at line 4)"),
    ("duplicate-param", OK_HEAD + "blocks:\n  a:\n    type: gain\n    gain: 1.0\n    gain: 2.0\n", 7, "duplicate key 'gain'"),
    ("unknown-type", OK_HEAD + "blocks:\n  a: {type: dealy}\n", 4, "block 'a': unknown type 'dealy' (did you mean 'delay'?)"),
    ("no-type", OK_HEAD + "blocks:\n  a: {length: 3}\n", 4, "block 'a': no `type`"),
    ("unknown-param", OK_HEAD + "blocks:\n  a:\n    type: delay\n    lenght: 3\n", 6, "block 'a' (delay): unknown parameter 'lenght' (did you mean 'length'?)"),
    ("wrong-type", OK_HEAD + "blocks:\n  a: {type: gain, gain: loud}\n", 4, "block 'a' (gain): parameter 'gain': 'loud' is not a number"),
    ("below-minimum", OK_HEAD + "blocks:\n  a:\n    type: delay\n    length: 0.5\n", 6, "parameter 'length': 0.5 is below the minimum 1.0 samples"),
    ("above-maximum", OK_HEAD + "blocks:\n  a: {type: mic, pan: 2}\n", 4, "parameter 'pan': 2 is above the maximum 1.0"),
    ("exclusive", OK_HEAD + "blocks:\n  a: {type: pluck, duration: 0}\n", 4, "parameter 'duration': 0 must be greater than 0.0 s"),
    ("bad-choice", OK_HEAD + "blocks:\n  a: {type: wavetable, shape: circle}\n", 4, "parameter 'shape': 'circle' is not one of 'sine'"),
    ("list-length", OK_HEAD + "blocks:\n  a: {type: scale, in_range: [1]}\n", 4, "parameter 'in_range': needs at least 2 item(s)"),
    ("cross-check", OK_HEAD + "blocks:\n  a:\n    type: scale\n    in_range: [1, 1]\n", 6, "in_range needs two different values"),
    ("allpass-short", OK_HEAD + "blocks:\n  a:\n    type: delay\n    interpolation: allpass\n    length: 1.2\n", 7, "allpass delay needs length"),
    ("nan", OK_HEAD + "blocks:\n  a: {type: gain, gain: .nan}\n", 4, "numbers must be finite"),
    ("infinite", OK_HEAD + "blocks:\n  a:\n    type: gain\n    gain: -.inf\n", 6, "numbers must be finite"),
    ("bad-rate", "hapticgraph: 1\nrate: -5\nblocks: {}\n", 2, "rate: -5 is below the minimum 100"),
    ("unknown-top-key", OK_HEAD + "blocks: {}\nconects: []\n", 1, "unknown key(s) 'conects'"),
    ("bad-block-name", OK_HEAD + "blocks:\n  my-block: {type: gain}\n", 3, "not a valid name"),
    ("bad-connection-syntax", OK_HEAD + "blocks:\n  a: {type: gain}\nconnect:\n  - a.out => a.in\n", 6, "cannot read 'a.out => a.in'"),
    ("unknown-block", OK_HEAD + "blocks:\n  a: {type: gain}\nconnect:\n  - a.out -> b.in\n", 6, "no block named 'b'"),
    ("unknown-port", OK_HEAD + "blocks:\n  a: {type: gain}\n  b: {type: gain}\nconnect:\n  - a.out -> b.inn\n", 7, "block 'b' (gain) has no input 'inn' (did you mean 'in'?)"),
    ("wrong-direction", OK_HEAD + "blocks:\n  a: {type: gain}\n  b: {type: gain}\nconnect:\n  - a.in -> b.in\n", 7, "'in' of block 'a' (gain) is an input"),
    ("into-output", OK_HEAD + "blocks:\n  a: {type: gain}\n  b: {type: gain}\nconnect:\n  - a.out -> b.out\n", 7, "'out' of block 'b' (gain) is an output"),
    ("static-param-input", OK_HEAD + "blocks:\n  a: {type: constant}\n  d: {type: delay}\nconnect:\n  - a.out -> d.length\n", 7, "parameter 'length' of block 'd' (delay) is not live"),
    ("cell-on-plain-block", OK_HEAD + "blocks:\n  a: {type: gain}\n  b: {type: gain}\nconnect:\n  - a[3].out -> b.in\n", 7, "has no cells"),
    ("algebraic-loop", OK_HEAD + "blocks:\n  a: {type: gain}\n  b: {type: gain}\nconnect:\n  - a.out -> b.in\n  - b.out -> a.in\n", 7, "algebraic loop: a -> b -> a"),
    ("self-loop", OK_HEAD + "blocks:\n  a: {type: gain}\nconnect:\n  - a.out -> a.in\n", 6, "algebraic loop: a -> a"),
    ("two-audio-outs", OK_HEAD + "blocks:\n  o1: {type: audio_out}\n  o2: {type: audio_out}\n", 5, "at most one audio_out"),
    ("plugin-missing-file", OK_HEAD + "plugins: [nowhere.py]\nblocks: {}\n", 3, "plugin file 'nowhere.py' not found"),
    ("plugin-missing-module", OK_HEAD + "plugins: [no_such_module_xyz]\nblocks: {}\n", 3, "plugin module 'no_such_module_xyz' cannot be imported"),
    ("non-string-key", OK_HEAD + "blocks:\n  [a, b]: {type: gain}\n", 4, "a key must be a plain string"),
]


@pytest.mark.parametrize("name,text,line,needle", CASES, ids=[c[0] for c in CASES])
def test_patch_error(tmp_path, capsys, name, text, line, needle):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert lines, "no message"
    assert all(re.match(rf"^{re.escape(str(path))}:\d+: \S", ln) for ln in lines), err
    assert any(ln.startswith(f"{path}:{line}: ") and needle in ln for ln in lines), err


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


@pytest.mark.parametrize("content,needle", [
    (b"\x7fELF\x02\x01\x01\x00\x00\x00", "binary file"),
    (b"hapticgraph: 1\nname: \xff\xfe\n", "not UTF-8"),
    (b"[" * 5000 + b"]" * 5000, "nested too deeply"),
])
def test_hostile_bytes(tmp_path, capsys, content, needle):
    path = tmp_path / "x.yaml"
    path.write_bytes(content)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


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
