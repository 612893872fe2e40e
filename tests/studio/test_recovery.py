"""The studio keeps the designer's work (issue 33, item 3): every accepted edit is kept in a
recovery file beside the patch (`.NAME.yaml.studio~`, written atomically, removed on save or when
the text is the file's again), offered when the studio next opens the patch (a `recovery` event
after `hello`; `recover` takes it through the loader, `discard_recovery` drops it), never trusted
blindly (its owner, its permissions, its size, a checksum of its text, then the loader); SIGTERM
and Ctrl-C stop the studio with one line, exit 0, the recovery file kept.

The process tests start `hapticgraph studio` on loopback (--audio none) and stop it by its PID;
the others drive a StudioSession through the command handler and Starlette's test client."""
import hashlib
import json
import os
import re
import shutil
import signal
import sys
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient

from project_env import ROOT
from hapticgraph.studio.commands import View, handle
from hapticgraph.studio.server import build_app
from hapticgraph.studio import session as session_module
from hapticgraph.studio.session import StudioSession
from studio_proc import Script, Studio, hello, next_event

TOKEN = "test-token"


@pytest.fixture
def sheet(tmp_path):
    shutil.copy(ROOT / "patches" / "cymatic_sheet.yaml", tmp_path / "sheet.yaml")
    return tmp_path / "sheet.yaml"


def recovery_of(path):
    return path.parent / f".{path.name}.studio~"


def three_edits(script):
    script.ok("set", block="mic1", param="gain", value=1.5)
    script.ok("lock", cell="sheet[1, 1]")
    script.ok("set", block="mic2", param="pan", value=0.25)
    return script.ok("state")["text"]


# -- the studio as a process -----------------------------------------------------------------------
def test_a_killed_studios_edits_come_back_on_the_next_start(sheet):
    original, mtime = sheet.read_bytes(), sheet.stat().st_mtime_ns
    first = Studio(sheet)
    try:
        with first.connect() as ws:
            hello(ws)
            edited = three_edits(Script(ws))
    finally:
        first.kill()                                                   # SIGKILL: no clean-up at all
    assert first.proc.returncode == -signal.SIGKILL
    assert sheet.read_bytes() == original and sheet.stat().st_mtime_ns == mtime
    assert recovery_of(sheet).is_file()

    second = Studio(sheet)
    try:
        with second.connect() as ws:
            assert hello(ws)["text"] == original.decode()              # the file, until the offer is taken
            offer = next_event(ws, "recovery")
            assert offer["offered"] and offer["edits"] == 3 and offer["text"] == edited, offer
            assert offer["patch_changed"] is False and offer["file"] == str(recovery_of(sheet))
            assert "+  mic1:  {type: mic, gain: 1.5, pan: -0.5}\n" in offer["diff"]
            script = Script(ws)
            refused = script.send("set", block="mic1", param="gain", value=1.0)     # answer the offer first
            assert not refused["ok"] and "recover" in refused["error"], refused
            assert script.ok("recover") == {"edits": 3, "undo": 1, "redo": 0}
            state = script.ok("state")
            assert state["text"] == edited and state["dirty"] and state["recovery"] is None
            assert sheet.read_bytes() == original                      # recovered, not saved
            assert recovery_of(sheet).is_file()                        # still kept until saved
            script.ok("save")
            assert sheet.read_text() == edited and not recovery_of(sheet).exists()
    finally:
        code, err = second.signal(signal.SIGTERM)
    assert code == 128 + signal.SIGTERM, err
    assert "3 unsaved edits" in err.splitlines()[0] and ".sheet.yaml.studio~" in err.splitlines()[0], err


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_ctrl_c_stop_with_one_line_and_keep_the_recovery(sheet, signum):
    studio = Studio(sheet)
    try:
        with studio.connect() as ws:
            hello(ws)
            script = Script(ws)
            script.ok("set", block="mic1", param="gain", value=1.5)
            edited = script.ok("state")["text"]
            code, err = studio.signal(signum)
    finally:
        studio.kill()
    lines = err.splitlines()
    assert code == 128 + signum, err        # as a shell reports a command a signal ended: 130, 143
    assert len(lines) == 2 and lines[0].startswith("hapticgraph: studio of 'Cymatic sheet'"), lines
    name = signal.Signals(signum).name
    assert re.fullmatch(rf"hapticgraph: studio stopped \({name}\); 1 unsaved edit kept in .*/\.sheet\.yaml\.studio~,"
                        r" offered when the studio opens sheet\.yaml again", lines[1]), lines[1]
    kept = recovery_of(sheet).read_text()
    assert kept.endswith(edited) and kept.startswith("# hapticgraph studio recovery")


# -- the recovery file -----------------------------------------------------------------------------
def run(st, cmd, **fields):
    reply = handle(st, {"cmd": cmd, **fields}, View(60))
    assert reply["ok"], reply
    return reply["result"]


@pytest.fixture
def session(sheet):
    opened = []

    def make(**kwargs):
        st = StudioSession(sheet, audio="none", **kwargs).start()
        opened.append(st)
        return st
    yield make
    for st in opened:
        st.close()


def test_each_edit_is_kept_atomically_and_saving_removes_it(sheet, session):
    st = session()
    kept = recovery_of(sheet)
    assert not kept.exists()
    run(st, "set", block="mic1", param="gain", value=1.5)
    text = kept.read_text()
    header, body = text.split("\n", 3)[:3], text.split("\n", 3)[3]
    assert body == st.text
    assert header[0] == "# hapticgraph studio recovery: 1 unsaved edit of sheet.yaml (delete these 3 lines to use it as a patch)"
    assert header[1] == "# base: sha256:" + hashlib.sha256(sheet.read_bytes()).hexdigest()
    assert header[2] == "# text: sha256:" + hashlib.sha256(st.text.encode()).hexdigest()
    assert kept.stat().st_mode & 0o777 == 0o600                         # private, like an editor's backup
    run(st, "set", block="mic2", param="pan", value=0.25)
    assert kept.read_text().startswith("# hapticgraph studio recovery: 2 unsaved edits")
    assert sorted(p.name for p in sheet.parent.iterdir()) == [kept.name, "sheet.yaml"]    # no temporary left
    run(st, "undo")
    run(st, "undo")                                                       # the file's text again: nothing to keep
    assert not kept.exists()
    run(st, "redo")
    assert kept.exists()
    run(st, "save")
    assert not kept.exists()


def test_the_offer_on_connect_and_discarding_it(sheet, session):
    st = session()
    run(st, "set", block="mic1", param="gain", value=1.5)
    st.close()
    notes = []
    st = session(note=notes.append)
    assert len(notes) == 1 and "1 unsaved edit" in notes[0] and "discard_recovery" in notes[0], notes
    with TestClient(build_app(st, TOKEN)).websocket_connect(f"/ws?token={TOKEN}") as ws:
        assert ws.receive_json()["type"] == "hello"
        offer = ws.receive_json()
        assert offer["type"] == "recovery" and offer["offered"] and offer["edits"] == 1
        ws.send_text(json.dumps({"id": 1, "cmd": "discard_recovery"}))
        got = [ws.receive_json() for _ in range(2)]
    assert {"type": "recovery", "offered": False, "cmd": "discard_recovery"} in got
    assert any(g.get("type") == "reply" and g["ok"] for g in got)
    assert not recovery_of(sheet).exists() and st.offer is None
    assert not handle(st, {"cmd": "recover"}, View(60))["ok"]             # nothing offered any more


def test_a_patch_changed_since_is_offered_and_said(sheet, session):
    st = session()
    run(st, "set", block="mic1", param="gain", value=1.5)
    edited = st.text
    st.close()
    sheet.write_text(sheet.read_text().replace("damping: 0.0008", "damping: 0.0009"))   # saved elsewhere
    st = session()
    assert st.offer is not None and st.offer.patch_changed
    event = st.offer.event()
    assert event["patch_changed"] is True and "+  sheet: {type: lattice" in event["diff"]
    run(st, "recover")
    assert st.text == edited and st.text != st.saved


def test_the_recovery_goes_through_the_loader(sheet, session):
    bad = sheet.read_text().replace("type: pluck", "type: plukc")
    digest = hashlib.sha256(bad.encode()).hexdigest()
    base = hashlib.sha256(sheet.read_bytes()).hexdigest()
    recovery_of(sheet).write_text(
        "# hapticgraph studio recovery: 1 unsaved edit of sheet.yaml (delete these 3 lines to use it as a patch)\n"
        f"# base: sha256:{base}\n# text: sha256:{digest}\n{bad}")
    recovery_of(sheet).chmod(0o600)
    st = session()
    assert st.offer is not None
    reply = handle(st, {"cmd": "recover"}, View(60))
    assert not reply["ok"] and re.match(r".*sheet\.yaml:\d+: .*plukc", reply["error"]), reply
    assert st.offer is not None and st.text == st.saved                  # nothing changed; still offered


@pytest.mark.parametrize("spoil, why", [("text", "checksum"), ("header", "first 3 lines"),
                                        ("mode", "others could have written it"), ("size", "larger than 8 MB"),
                                        ("link", "a link")])
def test_a_spoilt_recovery_file_is_not_offered(sheet, session, spoil, why):
    st = session()
    run(st, "set", block="mic1", param="gain", value=1.5)
    st.close()
    kept = recovery_of(sheet)
    if spoil == "text":
        kept.write_text(kept.read_text().replace("gain: 1.5", "gain: 1.6"))     # not what the checksum says
    elif spoil == "header":
        kept.write_text(kept.read_text().split("\n", 1)[1])
    elif spoil == "mode":
        kept.chmod(0o666)                                                          # others could have written it
    elif spoil == "size":
        with open(kept, "a") as f:
            f.write("#" * (9 << 20))
    else:                                                                          # a link to a file elsewhere
        elsewhere = sheet.parent / "elsewhere"
        kept.rename(elsewhere)
        kept.symlink_to(elsewhere)
    notes = []
    st = session(note=notes.append)
    assert st.offer is None
    assert len(notes) == 1 and notes[0].startswith(f"{kept}: not offered: ") and why in notes[0], notes


def test_the_undo_history_is_bounded_and_counts_what_it_holds(sheet, session, monkeypatch):
    st = session()
    size = sys.getsizeof(st.text)
    monkeypatch.setattr(session_module, "UNDO_BYTES", 5 * size + size // 2)       # room for five texts
    for i in range(8):
        run(st, "set", block="mic1", param="gain", value=1.0 + i / 10)
    assert len(st.undo_stack) == 5                                     # the oldest three dropped
    for _ in range(5):
        run(st, "undo")
    for _ in range(2):
        run(st, "redo")
    for i in range(3):                                                 # undo and redo kept the count right
        run(st, "set", block="mic1", param="gain", value=3.0 + i / 10)
    assert len(st.undo_stack) == 5 and not st.redo_stack
    assert st.undo_bytes == sum(sys.getsizeof(t) for t in st.undo_stack)
