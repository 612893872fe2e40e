"""The studio's WebSocket protocol (docs/studio.md) through Starlette's test client: the token
and the Origin, each command's reply, a bad edit refused with the loader's FILE:LINE and nothing
changed, save writing only the edited text, undo and redo, frames of the right shape. The sound
runs paced by the clock (--audio none / browser); every wait is bounded by a message count."""
import difflib
import json
import math
import re
import shutil
import struct
import time
import warnings

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from project_env import ROOT
from hapticgraph.graph.modes import modal_frequencies
from hapticgraph.studio.server import build_app
from hapticgraph.studio.session import StudioSession

TOKEN = "test-token"
MAX_MESSAGES = 20000        # any wait for a message gives up after this many others


class Page:
    """A scripted page: commands with ids, replies matched, frames and events kept."""

    def __init__(self, ws):
        self.ws, self.next_id = ws, 0
        self.frames, self.events = [], []
        self.hello = ws.receive_json()

    def receive(self):
        msg = self.ws.receive()
        if msg.get("type") == "websocket.close":
            raise AssertionError(f"the studio closed the socket: {msg}")
        if msg.get("bytes") is not None:
            self.frames.append(msg["bytes"])
            return None
        obj = json.loads(msg["text"])
        if obj.get("type") != "reply":
            self.events.append(obj)
        return obj

    def send(self, cmd, **fields):
        self.next_id += 1
        ident = self.next_id
        self.ws.send_text(json.dumps({"id": ident, "cmd": cmd, **fields}))
        for _ in range(MAX_MESSAGES):
            obj = self.receive()
            if obj is not None and obj.get("type") == "reply" and obj.get("id") == ident:
                return obj
        raise AssertionError(f"no reply to {cmd}")

    def ok(self, cmd, **fields):
        reply = self.send(cmd, **fields)
        assert reply["ok"], reply
        return reply["result"]

    def wait_frames(self, kind, count, ident=None):
        """The next `count` binary frames of `kind` (and id)."""
        got = []
        for _ in range(MAX_MESSAGES):
            while self.frames:
                f = self.frames.pop(0)
                if f[0] == kind and (ident is None or struct.unpack_from("<H", f, 2)[0] == ident):
                    got.append(f)
            if len(got) >= count:
                return got
            self.receive()
        raise AssertionError(f"fewer than {count} frames of kind {kind}")


def copy_patch(tmp_path, name="cymatic_sheet.yaml", extra=()):
    for n in (name, *extra):
        shutil.copy(ROOT / "patches" / n, tmp_path / n)
    return tmp_path / name


@pytest.fixture
def studio(tmp_path):
    st = StudioSession(copy_patch(tmp_path), audio="none", fps=60).start()
    yield st
    st.close()


@pytest.fixture
def client(studio):
    return TestClient(build_app(studio, TOKEN))


@pytest.fixture
def page(client):
    with client.websocket_connect(f"/ws?token={TOKEN}") as ws:
        yield Page(ws)


def cell_frame(data):
    kind, ndim, ident, counter, t = struct.unpack_from("<BBHIQ", data)
    shape = struct.unpack_from(f"<{ndim}I", data, 16)
    values = np.frombuffer(data, dtype="<f4", offset=16 + 4 * ndim)
    return kind, ident, counter, t, shape, values


def test_every_http_request_needs_the_token(client):
    assert client.get("/").status_code == 403
    assert client.get("/?token=wrong").status_code == 403
    assert client.get("/static/app.js").status_code == 403
    assert client.get(f"/?token={TOKEN}").status_code != 403
    client.cookies.set("hapticgraph_studio_token", TOKEN)
    assert client.get("/static/nothing.js").status_code == 404


def test_the_websocket_needs_the_token_and_its_own_origin(client):
    for url in ("/ws", "/ws?token=wrong"):
        with pytest.raises(WebSocketDisconnect):
            with client.websocket_connect(url) as ws:
                ws.receive_json()
    with pytest.raises(WebSocketDisconnect):
        with client.websocket_connect(f"/ws?token={TOKEN}", headers={"origin": "http://evil.example"}) as ws:
            ws.receive_json()
    with client.websocket_connect(f"/ws?token={TOKEN}", headers={"origin": "http://127.0.0.1:80"}) as ws:
        assert ws.receive_json()["type"] == "hello"


def test_hello_describes_the_instrument(page):
    hello = page.hello
    assert hello["type"] == "hello" and hello["version"] == 1
    assert [(s["name"], s["shape"]) for s in hello["lattices"]] == [("sheet", [12, 16])]
    assert hello["excitations"] == [{"block": "hit", "type": "pluck", "port": "out", "cell": "sheet[3, 4]",
                                     "lattice": 0, "index": [3, 4]}]
    assert [(m["block"], m["cell"], m["pan"]) for m in hello["microphones"]] == [
        ("mic1", "sheet[8, 11]", -0.5), ("mic2", "sheet[5, 13]", 0.5)]
    tension = next(p for p in hello["params"] if (p["block"], p["param"]) == ("sheet", "tension"))
    assert tension["unit"] == "N/m" and tension["live"] and tension["log"]
    assert 3400.0 < tension["stable_max"] < tension["max"]
    assert {"src": "hit.out", "dst": "sheet[3, 4].force"} in hello["graph"]["connections"]
    assert hello["dirty"] is False and hello["undo"] == 0


def test_cell_frames_have_the_lattices_shape_and_move(page):
    frames = [cell_frame(f) for f in page.wait_frames(1, 30)]
    kind, ident, _, _, shape, values = frames[-1]
    assert (kind, ident, shape, values.size) == (1, 0, (12, 16), 192)
    counters = [f[2] for f in frames]
    assert counters == sorted(counters) and len(set(counters)) == len(counters)
    assert frames[-1][3] > frames[0][3]                   # the sample index runs on
    assert np.all(np.isfinite(values)) and np.max(np.abs(values)) > 0   # struck at 10 ms


def test_a_live_set_changes_the_text_and_keeps_the_sound_running(page, studio):
    t0 = page.ok("state")["t"]
    assert page.ok("set", block="sheet", param="tension", value=3000.0) == {"value": 3000.0}
    state = page.ok("state")
    assert "tension: 3000.0" in state["text"] and state["dirty"] and state["undo"] == 1
    assert studio.live.session.params("sheet")["tension"] == 3000.0 or _settles(page, studio)
    assert state["t"] >= t0
    diff = page.ok("diff")["diff"]
    assert "-  sheet: {type: lattice, shape: [12, 16], mass: 0.0002, tension: 3400.0" in diff
    assert any(e["type"] == "changed" and e["cmd"] == "set" for e in page.events) or _changed_event(page)


def _settles(page, studio):
    page.wait_frames(1, 3)
    return studio.live.session.params("sheet")["tension"] == 3000.0


def _changed_event(page):
    for _ in range(MAX_MESSAGES):
        if any(e["type"] == "changed" for e in page.events):
            return True
        page.receive()
    return False


def test_a_bad_edit_gives_file_line_and_changes_nothing(page, studio):
    before = page.ok("state")["text"]
    runs = studio.live.session.program
    reply = page.send("set", block="sheet", param="tension", value=1e8)
    assert not reply["ok"]
    assert re.fullmatch(r".*cymatic_sheet\.yaml:25: block 'sheet' \(lattice\): unstable at 44100 Hz: .*", reply["error"])
    assert page.ok("state")["text"] == before and studio.live.session.program is runs
    assert studio.live.session.params("sheet")["tension"] == 3400.0
    for bad in ({"cmd": "lock", "cell": "sheet[40, 1]"}, {"cmd": "place", "block": "mic1", "cell": "nowhere[1]"},
                {"cmd": "set", "block": "sheet", "param": "colour", "value": 1.0}):
        reply = page.send(bad.pop("cmd"), **bad)
        assert not reply["ok"] and re.match(r"(.*\.yaml:\d+|studio): ", reply["error"]), reply
    assert page.ok("state") ["text"] == before
    assert not page.send("frobnicate")["ok"]


def test_save_changes_only_the_edited_text(page, studio, tmp_path):
    original = (tmp_path / "cymatic_sheet.yaml").read_text()
    page.ok("place", block="mic1", cell="sheet[2, 3]")
    page.ok("set", block="mic2", param="pan", value=0.25)
    assert (tmp_path / "cymatic_sheet.yaml").read_text() == original      # not saved yet
    result = page.ok("save")
    saved = (tmp_path / "cymatic_sheet.yaml").read_text()
    assert result["bytes"] == len(saved.encode())
    changed = [line for line in difflib.unified_diff(original.splitlines(True), saved.splitlines(True), n=0)
               if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    assert changed == ["-  mic2:  {type: mic, gain: 2.0, pan: 0.5}\n", "+  mic2:  {type: mic, gain: 2.0, pan: 0.25}\n",
                       "-  - sheet[8, 11].velocity -> mic1.in\n", "+  - sheet[2, 3].velocity -> mic1.in\n"]
    assert page.ok("state")["dirty"] is False
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cymatic_sheet.yaml"]     # no temporary left


def test_undo_and_redo_walk_the_texts(page):
    original = page.ok("state")["text"]
    page.ok("lock", cell="sheet[1, 1]")
    locked = page.ok("state")["text"]
    page.ok("cut", cells=["sheet[0, 0]", "sheet[0, 1]"])
    cut = page.ok("state")["text"]
    assert page.ok("undo") == {"undo": 1, "redo": 1}
    assert page.ok("state")["text"] == locked
    assert page.ok("undo") == {"undo": 0, "redo": 2}
    assert page.ok("state")["text"] == original
    assert not page.send("undo")["ok"]
    page.ok("redo")
    page.ok("redo")
    assert page.ok("state")["text"] == cut
    assert not page.send("redo")["ok"]


def test_cut_cells_come_as_nan_and_locked_cells_stay_at_rest(page):
    page.ok("cut", cell="sheet[0, 0]")
    page.ok("lock", cell="sheet[5, 5]")
    hello = page.ok("describe")
    assert hello["lattices"][0]["cut"] == [[0, 0]] and hello["lattices"][0]["locked"] == [[5, 5]]
    page.frames.clear()
    values = cell_frame(page.wait_frames(1, 5)[-1])[5].reshape(12, 16)
    assert math.isnan(values[0, 0]) and values[5, 5] == 0.0
    assert np.isfinite(values[1:, 1:]).all()
    assert np.max(np.abs(values[1:, 1:])) > 0        # the swaps kept the sheet moving (struck once, at 10 ms)


def test_join_place_remove_and_cells(page):
    assert page.ok("place", block="mic3", type="mic", cell="sheet[6, 6]", params={"pan": 0.1}) == {
        "block": "mic3", "cell": "sheet[6, 6]"}
    assert any(m["block"] == "mic3" and m["cell"] == "sheet[6, 6]" for m in page.ok("describe")["microphones"])
    page.ok("remove", block="mic3")
    page.ok("place", block="hit", cell="sheet[7, 7]")
    assert page.ok("describe")["excitations"][0]["cell"] == "sheet[7, 7]"
    page.ok("cells", block="sheet", cells=[[2, 2]], mass=0.0004)
    assert page.ok("describe")["lattices"][0]["cells"] == [{"index": [2, 2], "mass": 0.0004}]
    assert page.ok("join", a="sheet[1, 1]", b="sheet[10, 14]", tension=100.0) == {"block": "join1"}
    assert page.ok("describe")["joins"][0]["a"] == "sheet[1, 1]"


def test_modes_and_mode_shapes(page, studio):
    nets = page.ok("modes", count=4)["networks"]
    assert nets[0]["frequencies"] == pytest.approx(modal_frequencies(studio.patch, 4)["sheet"])
    shape = page.ok("mode_shape", lattice="sheet", mode=1)
    assert shape["shape"] == [12, 16] and len(shape["values"]) == 192
    assert shape["frequency"] == pytest.approx(nets[0]["frequencies"][0])
    assert max(abs(v) for v in shape["values"]) == pytest.approx(1.0)


def test_probe_streams_a_signal(page):
    reply = page.ok("probe", signal="sheet[8, 11].velocity")
    assert reply["rate"] == 44100.0
    frames = page.wait_frames(3, 3, reply["probe"])
    kind, zero, ident, counter, t0, rate, n = struct.unpack_from("<BBHIQII", frames[-1])
    assert (ident, rate, n, len(frames[-1])) == (reply["probe"], 44100, n, 24 + 4 * n) and n > 100
    assert not page.send("probe", signal="sheet[99, 1].velocity")["ok"]
    page.ok("unprobe", probe=reply["probe"])


def test_frames_command_limits_what_a_page_receives(page):
    assert page.ok("frames", fps=0) == {"fps": 0.0}
    page.ok("state")                  # a frame being sent as the command arrived comes before this
    page.frames.clear()
    for _ in range(20):
        page.ok("state")
    assert not [f for f in page.frames if f[0] == 1]
    assert page.ok("frames", fps=1000)["fps"] == 60.0


def test_map_writes_the_map_section(tmp_path):
    path = copy_patch(tmp_path, "midi_melody.yaml", ("melody.mid",))
    st = StudioSession(path, audio="none").start()
    try:
        with TestClient(build_app(st, TOKEN)).websocket_connect(f"/ws?token={TOKEN}") as ws:
            page = Page(ws)
            assert page.hello["map"][0]["cc"] == 74
            page.ok("map", entries=[{"param": "tone.amplitude", "cc": 1, "min": 0.1, "max": 0.3}])
            assert "  - {param: tone.amplitude, cc: 1, min: 0.1, max: 0.3}\n" in page.ok("state")["text"]
            reply = page.send("map", entries=[{"param": "tone.nothing", "cc": 1}])
            assert not reply["ok"] and "midi_melody.yaml:" in reply["error"]
    finally:
        st.close()


def test_audio_in_the_browser(tmp_path):
    st = StudioSession(copy_patch(tmp_path), audio="browser").start()
    try:
        with TestClient(build_app(st, TOKEN)).websocket_connect(f"/ws?token={TOKEN}") as ws:
            page = Page(ws)
            assert page.hello["audio"] == {"mode": "browser", "rate": 44100.0, "blocksize": 256, "channels": 2}
            frames = page.wait_frames(2, 4)
            kind, channels, _, counter, t0, rate, n = struct.unpack_from("<BBHIQII", frames[-1])
            assert (channels, rate, len(frames[-1])) == (2, 44100, 24 + 4 * 2 * n)
            starts = [struct.unpack_from("<Q", f, 8)[0] for f in frames]
            assert all(b - a == n for a, b in zip(starts, starts[1:]))     # consecutive blocks, none lost
    finally:
        st.close()


def test_save_as_writes_a_new_patch_beside_the_old_one(page, tmp_path):
    page.ok("set", block="mic1", param="gain", value=1.5)
    assert not page.send("save", path="notes.txt")["ok"]
    result = page.ok("save", path="edited.yaml")
    assert result["path"].endswith("edited.yaml") and (tmp_path / "edited.yaml").read_text().count("gain: 1.5") == 1
    assert "gain: 2.0" in (tmp_path / "cymatic_sheet.yaml").read_text().split("mic1:")[1].splitlines()[0]
    assert page.ok("state")["path"].endswith("edited.yaml")


def _event(page, kind):
    for _ in range(MAX_MESSAGES):
        for e in page.events:
            if e["type"] == kind:
                return e
        page.receive()
    raise AssertionError(f"no {kind} event")


def test_a_safety_stop_is_reported_and_the_next_edit_plays_again(page, studio):
    page.ok("set", block="mic1", param="gain", value=1e9)        # the audio runs away
    problem = _event(page, "problem")
    assert re.match(r"runaway: out\.(left|right) reached .* over the limit 1000", problem["message"]), problem
    assert page.ok("state")["problem"] == problem["message"]
    stopped = page.ok("state")["t"]
    page.ok("set", block="mic1", param="gain", value=2.0)        # swapped in: the sound goes on
    assert page.ok("state")["problem"] is None
    page.frames.clear()
    frames = [cell_frame(f) for f in page.wait_frames(1, 10)]
    assert frames[-1][3] > stopped * 44100


def test_undo_after_a_runaway_of_the_state_plays_again_from_rest(page, studio):
    """The state ran away (a strike a million times too hard): undo to the right strike plays it
    from rest (kept, the state runs away again at once and the sound would stay stopped)."""
    page.ok("set", block="hit", param="force", value=1e6)
    page.ok("restart")
    assert _event(page, "problem")["message"].startswith("runaway")
    page.ok("undo")
    page.events.clear()
    first = page.ok("state")["t"]
    time.sleep(1.0)
    state = page.ok("state")
    assert state["problem"] is None and not [e for e in page.events if e["type"] == "problem"], state["problem"]
    assert state["t"] - first > 0.3, (first, state["t"])


def test_restart_starts_from_rest_and_text_replaces_the_patch(page):
    page.wait_frames(1, 20)
    before = page.ok("state")["t"]
    page.ok("restart")
    assert page.ok("state")["t"] < before
    text = page.ok("state")["text"]
    page.ok("text", text=text.replace("pan: 0.5}", "pan: 0.75}"))
    assert [m["pan"] for m in page.ok("describe")["microphones"]] == [-0.5, 0.75]
    reply = page.send("text", text=text.replace("type: pluck", "type: plukc"))
    assert not reply["ok"] and "plukc" in reply["error"] and re.match(r".*cymatic_sheet\.yaml:\d+: ", reply["error"])
    assert "pan: 0.75}" in page.ok("state")["text"]


def test_the_sets_of_one_gesture_are_one_undo_entry(page):
    """A slider's drag sends its sets with one `gesture`: one entry to undo, back to before the drag."""
    for gain in (2.5, 3.0, 3.5):
        page.ok("set", block="mic1", param="gain", value=gain, gesture="drag-1")
    assert page.ok("state")["undo"] == 1
    page.ok("set", block="mic1", param="gain", value=4.0, gesture="drag-2")
    page.ok("set", block="mic1", param="gain", value=4.5)
    assert page.ok("state")["undo"] == 3
    page.ok("undo")
    page.ok("undo")
    assert page.ok("undo")["undo"] == 0
    assert [p["value"] for p in page.ok("describe")["params"] if (p["block"], p["param"]) == ("mic1", "gain")] == [2.0]
    reply = page.send("set", block="mic1", param="gain", value=2.5, gesture=[1])
    assert not reply["ok"] and "gesture" in reply["error"]


def test_the_icon_is_served_at_both_addresses(client):
    for url in (f"/favicon.ico?token={TOKEN}", f"/static/favicon.svg?token={TOKEN}"):
        r = client.get(url)
        assert r.status_code == 200 and r.headers["content-type"].startswith("image/svg+xml") and b"<svg" in r.content
    assert client.get("/favicon.ico").status_code == 403
