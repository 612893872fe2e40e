"""`hapticgraph studio` as a process: its first line, the token on HTTP and the WebSocket, the
Origin check against a real server, the sound card (a JACK dummy server) pacing the session, and
a patch error (exit 2, nothing served). Every wait has a deadline; the process is stopped by its
PID."""
import json
import os
import re
import select
import shutil
import signal
import struct
import subprocess
import sys
import time
import urllib.error
import urllib.request

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from audio_env import jack_or_skip
from project_env import ROOT

FIRST_LINE = re.compile(r"hapticgraph studio: http://127\.0\.0\.1:(\d+)/\?token=([A-Za-z0-9_\-]{20,})\n")


def start(path, *args, env=None):
    """(process, first line): `hapticgraph studio PATH --no-browser ...`."""
    proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "studio", str(path), "--no-browser", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    ready, _, _ = select.select([proc.stdout], [], [], 120)
    line = proc.stdout.readline() if ready else ""
    if not line:
        stop(proc)
        pytest.fail(f"no first line from the studio: {proc.stderr.read()}")
    return proc, line


def stop(proc):
    """SIGTERM (as Ctrl-C); the exit status."""
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGTERM)
    try:
        return proc.wait(20)
    except subprocess.TimeoutExpired:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        pytest.fail("the studio did not stop on SIGTERM")


def status(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as exc:
        return exc.code


def replies(ws, ident, limit=5000):
    """The reply to command `ident` (frames and events read past, at most `limit`)."""
    for _ in range(limit):
        msg = ws.recv(timeout=30)
        if isinstance(msg, str):
            obj = json.loads(msg)
            if obj.get("type") == "reply" and obj.get("id") == ident:
                return obj
    raise AssertionError(f"no reply to {ident}")


def event(ws, kind, limit=5000):
    for _ in range(limit):
        msg = ws.recv(timeout=30)
        if isinstance(msg, str) and json.loads(msg).get("type") == kind:
            return json.loads(msg)
    raise AssertionError(f"no {kind} event")


def cell_frames(ws, count, limit=5000):
    got = []
    for _ in range(limit):
        msg = ws.recv(timeout=30)
        if isinstance(msg, bytes) and msg[0] == 1:
            got.append(struct.unpack_from("<BBHIQ", msg))
            if len(got) == count:
                return got
    raise AssertionError("too few cell frames")


@pytest.fixture
def sheet(tmp_path):
    shutil.copy(ROOT / "patches" / "cymatic_sheet.yaml", tmp_path / "sheet.yaml")
    return tmp_path / "sheet.yaml"


def test_first_line_token_and_origin(sheet):
    proc, line = start(sheet, "--audio", "none")
    try:
        m = FIRST_LINE.fullmatch(line)
        assert m, line
        port, token = m.groups()
        base = f"http://127.0.0.1:{port}"
        assert status(f"{base}/") == 403 and status(f"{base}/?token=x{token}") == 403
        assert status(f"{base}/static/x.js") == 403
        ws_url = f"ws://127.0.0.1:{port}/ws?token={token}"
        for url, origin in ((f"ws://127.0.0.1:{port}/ws", None), (ws_url, "http://evil.example"),
                            (ws_url, f"http://127.0.0.1:{int(port) + 1}")):
            with pytest.raises(InvalidStatus):
                with connect(url, origin=origin, open_timeout=10):
                    pass
        for origin in (None, f"http://127.0.0.1:{port}", f"http://localhost:{port}"):
            with connect(ws_url, origin=origin, open_timeout=10, max_size=None) as ws:
                assert json.loads(ws.recv(timeout=30))["type"] == "hello"
        with connect(ws_url, open_timeout=10, max_size=None) as ws:
            ws.recv(timeout=30)
            frames = cell_frames(ws, 10)
            ws.send(json.dumps({"id": 1, "cmd": "set", "block": "sheet", "param": "damping", "value": 0.001}))
            assert replies(ws, 1)["ok"]
        assert frames[-1][3] > frames[0][3]
    finally:
        code = stop(proc)
    assert code == 128 + signal.SIGTERM, proc.stderr.read()
    assert "damping: 0.0008," in sheet.read_text()        # not saved: the file is as it was


def test_a_patch_with_errors_exits_2_before_serving(write_patch):
    path = write_patch("""
        hapticgraph: 1
        blocks:
          s: {type: lattice, shape: [4], tension: -1.0}
        """)
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "studio", str(path), "--no-browser",
                           "--audio", "none"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert re.match(r".*p\.yaml:3: block 's' \(lattice\): parameter 'tension'", proc.stderr), proc.stderr


def test_the_sound_card_paces_the_studio(sheet, tmp_path):
    jack = jack_or_skip(tmp_path)
    try:
        proc, line = start(sheet, "--audio", "card", "--audio-device", "system", "--blocksize", "64", env=jack.env)
        try:
            port, token = FIRST_LINE.fullmatch(line).groups()
            with connect(f"ws://127.0.0.1:{port}/ws?token={token}", open_timeout=10, max_size=None) as ws:
                hello = json.loads(ws.recv(timeout=30))
                assert hello["audio"]["mode"] == "card"
                began = time.monotonic()
                frames = cell_frames(ws, 40)
                wall = time.monotonic() - began
                ws.send(json.dumps({"id": 1, "cmd": "place", "block": "mic1", "cell": "sheet[1, 1]"}))
                assert replies(ws, 1)["ok"]
                after = cell_frames(ws, 5)
                ws.send(json.dumps({"id": 2, "cmd": "set", "block": "mic1", "param": "gain", "value": 1e9}))
                problem = event(ws, "problem")                  # the stream stops, the studio stays
                ws.send(json.dumps({"id": 3, "cmd": "set", "block": "mic1", "param": "gain", "value": 1.0}))
                assert replies(ws, 3)["ok"]                       # the stream opens again
                again = cell_frames(ws, 5)
        finally:
            code = stop(proc)
    finally:
        jack.stop()
    assert code == 128 + signal.SIGTERM, proc.stderr.read()
    played = (frames[-1][4] - frames[0][4]) / 44100
    assert 0 < played < 3.0 * wall + 0.5                      # paced by the card, not as fast as possible
    assert after[0][4] > frames[-1][4]                        # the swap kept the clock running
    assert problem["message"].startswith("runaway: ") and again[-1][4] > again[0][4] > after[-1][4]


def test_without_audio_option_the_page_plays_when_there_is_no_sound_card(sheet, tmp_path):
    env = dict(os.environ, XDG_CONFIG_HOME=str(tmp_path), JACK_NO_START_SERVER="1",
               JACK_DEFAULT_SERVER="hapticgraph-no-server")      # no JACK server: only what ALSA has
    proc, line = start(sheet, env=env)
    try:
        port, token = FIRST_LINE.fullmatch(line).groups()
        with connect(f"ws://127.0.0.1:{port}/ws?token={token}", open_timeout=10, max_size=None) as ws:
            mode = json.loads(ws.recv(timeout=30))["audio"]["mode"]
    finally:
        stop(proc)
    err = proc.stderr.read()
    assert mode == ("browser" if "no sound card" in err else "card"), err
