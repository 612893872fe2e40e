"""Hostile takes (.hgrec): a take names no code — a header that names a module (`os:system`, or
a module beside it that would write a file on import) imports nothing; a malformed take is one
line naming the file, exit 2, no traceback; every replay path checks the take against the patch."""
import json
import struct

import numpy as np
import pytest

from hapticgraph import load
from hapticgraph.devices.record import MAGIC, PREAMBLE, fingerprint, header_bytes, patch_signature

from hostile_env import assert_patch_error, run_hg

PATCH = """\
hapticgraph: 1
name: plucked
rate: 44100
devices:
  finger: {driver: simulated, max_force: 4.0, script: [{t: 0.0, x: -0.002}, {t: 0.05, x: 0.004}]}
blocks:
  str: {type: lattice, shape: [12], mass: 0.001, tension: 200000.0, damping: 0.01}
  pick: {type: haptic, device: finger}
  pl: {type: plucker, k: 2000.0, release: 2.0}
  out: {type: audio_out, channels: 1}
connect:
  - pick.x -> pl.x1
  - pick.v -> pl.v1
  - str[4].position -> pl.x2
  - str[4].velocity -> pl.v2
  - pl.reaction -> pick.force
  - pl.force -> str[4].force
  - str[8].velocity -> out.ch0
"""


def header_for(patch_path):
    """The header `play --record` writes for PATCH (simulated finger: hand_x, hand_v, force)."""
    sig = patch_signature(load(patch_path))
    return {
        "format": "hapticgraph take", "version": 1,
        "patch": {"name": "plucked", "file": "p.yaml", "fingerprint": fingerprint(sig), "signature": sig},
        "rate": sig["rate"], "columns": [["finger", "hand_x"], ["finger", "hand_v"], ["finger", "force"]],
        "inputs": 2, "forces": ["finger"],
        "drivers": {"finger": {"kind": "simulated", "columns": ["hand_x", "hand_v"], "offset": 0,
                               "model": "simulated",
                               "block_values": {"mass": 0.05, "hand_stiffness": 400.0, "hand_damping": 4.0,
                                                "max_force": 4.0, "x0": -0.002}, "input": False}},
        "audio": {"channels": 1}, "blocksize": 64,
    }


def write_take(path, header, rows=None):
    rows = np.zeros((441, 3)) if rows is None else rows
    path.write_bytes(header_bytes(header) + np.ascontiguousarray(rows, dtype="<f8").tobytes())
    return path


@pytest.fixture
def setup(tmp_path):
    patch = tmp_path / "p.yaml"
    patch.write_text(PATCH)
    return tmp_path, patch


def replay_everywhere(tmp_path, patch, take):
    """`run --replay TAKE` and a device entry `{driver: replay, file: TAKE}`: both CompletedProcesses."""
    out = tmp_path / "o.wav"
    a = run_hg("run", patch, "--replay", take, "--out", out, "--quiet", "--seconds", "0.01", cwd=tmp_path)
    entry = tmp_path / "entry.yaml"
    entry.write_text(PATCH.replace("{driver: simulated, max_force: 4.0, script: [{t: 0.0, x: -0.002}, "
                                   "{t: 0.05, x: 0.004}]}", f"{{driver: replay, file: {take.name}}}"))
    b = run_hg("run", entry, "--out", out, "--quiet", "--seconds", "0.01", cwd=tmp_path)
    assert not out.exists()
    return a, b


@pytest.mark.parametrize("where", ["legacy block_type", "model"])
@pytest.mark.parametrize("target", ["os:system", "planted_module:thing"])
def test_a_take_that_names_a_module_imports_nothing(setup, where, target):
    tmp_path, patch = setup
    planted = tmp_path / "planted_module.py"
    marker = tmp_path / "PWNED"
    planted.write_text(f"open({str(marker)!r}, 'w').write('imported')\nthing = object\n")
    header = header_for(patch)
    info = header["drivers"]["finger"]
    del info["model"]
    info["block_type" if where == "legacy block_type" else "model"] = target
    take = write_take(tmp_path / "evil.hgrec", header)
    for proc in replay_everywhere(tmp_path, patch, take):
        assert_patch_error(proc, "evil.hgrec")
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    # the module is importable from where hapticgraph runs, yet it was never imported
    assert not marker.exists()


def pack(body, version=1, length=None):
    """A take's preamble and header from raw header bytes (the length field as given, or true)."""
    body += b" " * ((-(PREAMBLE + len(body))) % 8)
    return MAGIC + struct.pack("<H", version) + struct.pack("<Q", len(body) if length is None else length) + body


def _mutations(patch):
    h = header_for(patch)
    text = json.dumps(h)

    def header(change=None, replace=None):
        hh = json.loads(text)
        if change is not None:
            change(hh)
        body = json.dumps(hh)
        for old, new in (replace or {}).items():
            body = body.replace(old, new)
        return pack(body.encode()) + np.zeros((10, 3)).tobytes()

    good = pack(text.encode())
    rows = np.zeros((10, 3))
    nan_rows, inf_rows = rows.copy(), rows.copy()
    nan_rows[3, 1] = np.nan
    inf_rows[7, 2] = np.inf
    return {
        "empty file": (b"", "not a hapticgraph take"),
        "truncated preamble": (good[:9], "not a hapticgraph take"),
        "wrong magic": (b"HGREX\x00" + good[6:], "not a hapticgraph take"),
        "header longer than the file": (good[:PREAMBLE + 40], "truncated"),
        "header length 2**63": (pack(text.encode(), length=1 << 63), "truncated"),
        "bad JSON": (pack(b"{" * 8 + text.encode()[8:]), "not valid JSON"),
        "not UTF-8": (pack(b"\xff" * 64), "not valid JSON"),
        "NaN in the JSON": (header(lambda x: x.update(rate="NAN"), {'"NAN"': "NaN"}), "not valid JSON"),
        "a rate that is not its patch's": (header(lambda x: x.update(rate=48000.0)), "is not its patch's"),
        "deep JSON": (header(lambda x: x.update(audio="DEEP"), {'"DEEP"': "[" * 3000 + "]" * 3000}), "bad.hgrec"),
        "header is a list": (pack(b"[1, 2, 3]"), "the header"),
        "non-multiple row count": (good + rows.tobytes() + b"\x00" * 5, "5 bytes more"),
        "NaN in the data": (good + nan_rows.tobytes(), "sample 3, column finger.hand_v is nan"),
        "inf in the data": (good + inf_rows.tobytes(), "sample 7, column finger.force is inf"),
        "columns not matching inputs": (header(lambda x: x.update(inputs=1)), "columns"),
        "driver columns beyond the inputs": (header(lambda x: x["drivers"]["finger"].update(offset=2)),
                                             "do not match"),
        "a force column missing": (header(lambda x: x.update(forces=[])), "columns"),
        "columns not pairs": (header(lambda x: x.update(columns=[["finger"], 3, None])), "columns"),
        "absurd max_force in the model": (header(
            lambda x: x["drivers"]["finger"]["block_values"].update(max_force=1e9)), "max_force"),
        "a model value that is no parameter": (header(
            lambda x: x["drivers"]["finger"]["block_values"].update(device=1.0)), "unknown model value 'device'"),
        "5000-digit integer": (header(lambda x: x.update(blocksize="BIG"), {'"BIG"': "9" * 5000}),
                               "not valid JSON"),
        "another version": (pack(text.encode(), version=7), "version 7"),
    }


@pytest.mark.parametrize("name", ["empty file", "truncated preamble", "wrong magic", "header longer than the file",
                                  "header length 2**63", "bad JSON", "not UTF-8", "NaN in the JSON", "deep JSON",
                                  "header is a list", "a rate that is not its patch's", "non-multiple row count", "NaN in the data",
                                  "inf in the data", "columns not matching inputs",
                                  "driver columns beyond the inputs", "a force column missing",
                                  "columns not pairs", "absurd max_force in the model",
                                  "a model value that is no parameter", "5000-digit integer", "another version"])
def test_a_malformed_take_is_one_line_naming_it(setup, name):
    tmp_path, patch = setup
    data, fragment = _mutations(patch)[name]
    take = tmp_path / "bad.hgrec"
    take.write_bytes(data)
    for proc in replay_everywhere(tmp_path, patch, take):
        assert_patch_error(proc, "bad.hgrec")
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and fragment in lines[0], proc.stderr


def test_a_fifo_given_as_a_take_is_refused_without_blocking(setup):
    import os
    tmp_path, patch = setup
    fifo = tmp_path / "pipe.hgrec"
    os.mkfifo(fifo)
    proc = run_hg("run", patch, "--replay", fifo, "--out", tmp_path / "o.wav", "--quiet", timeout=30)
    assert_patch_error(proc, "not a regular file")


def test_every_replay_path_checks_the_take_against_the_patch(setup):
    """A well-formed take of another patch: refused by `run --replay`, by a device entry
    `driver: replay` (another rate; other axes), before anything renders."""
    tmp_path, patch = setup
    other_rate = tmp_path / "rate.yaml"
    other_rate.write_text(PATCH.replace("rate: 44100", "rate: 48000"))
    take = write_take(tmp_path / "t.hgrec", header_for(other_rate))
    a, b = replay_everywhere(tmp_path, patch, take)
    assert_patch_error(a, "was recorded from another patch")
    assert_patch_error(b, "t.hgrec was recorded at 48000 Hz; entry.yaml runs at 44100 Hz")
    # the same rate, but the recorded device had another axis (a script key `button`)
    axes = tmp_path / "axes.yaml"
    axes.write_text(PATCH.replace("{t: 0.05, x: 0.004}", "{t: 0.05, x: 0.004, button: 1}"))
    h = header_for(axes)
    h["columns"].insert(2, ["finger", "button"])
    h["inputs"] = 3
    h["drivers"]["finger"]["columns"].append("button")
    take = write_take(tmp_path / "t.hgrec", h, np.zeros((441, 4)))
    a, b = replay_everywhere(tmp_path, patch, take)
    assert_patch_error(a, "was recorded from another patch")
    assert_patch_error(b, "device 'finger' of t.hgrec has the axes x, v, button; in entry.yaml it has x, v")
    # a take of this patch replays
    take = write_take(tmp_path / "t.hgrec", header_for(patch))
    ok = run_hg("run", patch, "--replay", take, "--out", tmp_path / "ok.wav", "--quiet", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
