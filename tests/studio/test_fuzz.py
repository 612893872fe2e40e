"""A hostile page or script cannot break the studio (issue 33, item 5): a few thousand malformed,
oversized, wrong-typed and out-of-order commands, binary frames where text is expected, text
frames that are not UTF-8, and a flood of `set`s while another connection never reads, all sent
to `hapticgraph studio` on loopback over real sockets. Each is answered with `ok: false` and a
reason, or its connection is closed (a message over the size limit, a text frame that is not
UTF-8); the server never dies, writes the patch file never (no `save` is sent that could
succeed), keeps its memory bounded, and answers a good command afterwards.

The commands come from a seeded generator (SEED): the same run every time. Commands that would
be accepted and compile a new kernel (a new shape, new wiring) are kept out, so that the run is
bounded in time; accepted edits of live parameters are in (the flood)."""
import asyncio
import contextlib
import json
import random
import re
import resource
import shutil
import signal
import socket
import threading
import time
import warnings

import pytest
from websockets.exceptions import ConnectionClosed, InvalidStatus

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient

from project_env import ROOT
from hapticgraph.studio import commands
from hapticgraph.studio.server import MAX_CONNECTIONS, MAX_MESSAGE, Mailbox, build_app
from hapticgraph.studio.session import StudioSession
from studio_proc import Studio, hello, reply

SEED = 33
COUNT = 3000               # fuzzed messages
FLOOD = 1000               # `set`s, each taken back by an `undo`: 2000 accepted edits, sent without waiting
IN_FLIGHT = 64             # commands of the flood sent ahead of their replies (~2 s of work)
TIME_LIMIT_S = 600         # the whole run, on a loaded machine (it takes about a tenth of this alone)
ADDRESS_SPACE = 6 << 30    # the server's RLIMIT_AS: a runaway fails the test, not the machine
# Resident memory (VmRSS; VmHWM for a peak) the server may gain:
# - over the fuzz: messages of up to MAX_MESSAGE and more (the oversized ones are read up to the
#   limit before the socket is closed), deep and long JSON, which the allocator may keep for
#   later; a few times MAX_MESSAGE for each of the 34 connections the fuzz opens would still be
#   in bound. Measured: about 11 MB.
FUZZ_LIMIT = 32 << 20
# - at its peak during the flood: nothing by design. The flood's edits leave the undo history as
#   it was (each set is undone); for the page that never reads the server keeps the latest
#   `changed` event and at most 64 others; commands are read one at a time. Unbounded (before the
#   mailbox coalesced `changed` events), that page held every one once its socket's buffers were
#   full: the instrument's description, ~6.6 kB as JSON and ~10 kB of resident memory each,
#   2000 of them: ~20 MB (measured: 20.7 MiB). Measured now: under 1 MB.
FLOOD_LIMIT = 4 << 20

REFUSAL = r"^(studio: |.*sheet\.yaml:\d+: )"
BLOCKS = ("sheet", "hit", "mic1", "mic2", "out")
PARAMS = ("mass", "tension", "damping", "gain", "pan", "time", "force", "duration")
COMMANDS = ("describe", "state", "diff", "save", "undo", "redo", "set", "lock", "unlock", "cut", "cells", "join",
            "place", "remove", "map", "text", "modes", "mode_shape", "probe", "unprobe", "frames", "restart",
            "recover", "discard_recovery")
FIELDS = ("block", "param", "value", "cell", "cells", "a", "b", "tension", "port", "type", "params", "entries",
          "text", "path", "count", "lattice", "mode", "signal", "probe", "fps", "lattices", "mass", "damping", "id")


@pytest.fixture
def sheet(tmp_path):
    shutil.copy(ROOT / "patches" / "cymatic_sheet.yaml", tmp_path / "sheet.yaml")
    return tmp_path / "sheet.yaml"


def _limit():
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


class Nasty:
    """Values of every JSON type, chosen to be wrong: names that are not in the patch, cells out
    of range, numbers at the edges, deep and long containers, odd strings."""

    def __init__(self, rng):
        self.rng = rng

    def string(self):
        r = self.rng
        return r.choice([
            "", " ", "sheet[", "sheet[99, 99]", "sheet[-1, 0]", "sheet[1, 2, 3]", "nowhere[1]", "mic1.nothing",
            "x" * r.randrange(1, 5000), "\u0000\ud7ff\ufffe", "é" * 300, "../../../etc/passwd", "sheet[1,1]]",
            "hit.out -> sheet[3, 4].force", "{{}}", "a" * 64 + ".yamlx", "\n" * 50, r.choice(BLOCKS) + "_",
            "".join(chr(r.randrange(32, 0x2FFF)) for _ in range(r.randrange(1, 40)))])

    def number(self):
        r = self.rng
        return r.choice([0, -1, 1, 2 ** 63, -(2 ** 63) - 1, 10 ** 30, 1e308, -1e308, 5e-324, 0.5, -0.0,
                         r.uniform(-1e9, 1e9), r.randrange(-1000, 1000)])

    def value(self, depth=0):
        r = self.rng
        kind = r.randrange(7 if depth < 3 else 4)
        if kind == 0:
            return None
        if kind == 1:
            return r.random() < 0.5
        if kind == 2:
            return self.number()
        if kind == 3:
            return self.string()
        if kind == 4:
            return [self.value(depth + 1) for _ in range(r.randrange(0, 6))]
        if kind == 5:
            return {self.string(): self.value(depth + 1) for _ in range(r.randrange(0, 4))}
        return [[r.randrange(-3, 20), r.randrange(-3, 20)] for _ in range(r.randrange(0, 300))]


def command(rng, nasty):
    """One fuzzed text message (a str) that the server must answer with exactly one reply."""
    kind = rng.randrange(10)
    if kind == 0:                                            # not an object
        return json.dumps(nasty.value())
    if kind == 1:                                            # not JSON
        good = json.dumps({"cmd": rng.choice(COMMANDS), "block": "mic1"})
        return rng.choice([good[:rng.randrange(len(good))], "{", "}", "[" * rng.randrange(1, 200000),
                           "{\"cmd\": \"set\",}", "NaN]", "\ufeff{}", "{\"cmd\": \"state\"} {}",
                           "".join(chr(rng.randrange(1, 0xD7FF)) for _ in range(rng.randrange(1, 200)))])
    if kind == 2:                                            # deep nesting inside an object
        depth = rng.choice([100, 1000, 5000, 100000])
        return '{"cmd": "set", "id": ' + "[" * depth + "]" * depth + ', "value": ' + "{\"a\":" * 50 + "1" + "}" * 50 + "}"
    if kind == 3:                                            # out of order: nothing to undo, no offer, no probe
        return json.dumps({"cmd": rng.choice(["undo", "redo", "recover", "discard_recovery", "unprobe"]),
                           "probe": rng.randrange(-5, 100), "id": rng.randrange(10 ** 6)})
    if kind == 4:                                            # a refused set: real names, wrong values
        return json.dumps({"cmd": "set", "block": rng.choice(BLOCKS), "param": rng.choice(PARAMS + ("shape", "type")),
                           "value": rng.choice([nasty.value(), -1.0, 1e30, [], "fast"]), "id": "s"},
                          allow_nan=False)
    if kind == 5:                                            # numbers JSON does not have
        return rng.choice(['{"cmd": "frames", "fps": NaN}', '{"cmd": "frames", "fps": Infinity, "lattices": [1e999]}',
                           '{"cmd": "set", "block": "mic1", "param": "gain", "value": -Infinity}',
                           '{"cmd": "cells", "block": "sheet", "cells": [[1, 1]], "mass": NaN}',
                           '{"cmd": "modes", "count": ' + "9" * 5000 + "}"])
    if kind == 6:                                            # save, never to a patch file
        return json.dumps({"cmd": "save", "path": rng.choice([3, [], {}, True, "notes.txt", "x.yaml/", "",
                                                              "sheet.yaml.bak", "../x.json"])})
    if kind == 7:                                            # a known command with wrong fields
        msg = {"cmd": rng.choice(COMMANDS), "id": nasty.value()}
        for _ in range(rng.randrange(0, 5)):
            msg[rng.choice(FIELDS)] = nasty.value()
        if msg["cmd"] == "save" or "path" in msg:       # a save-as could succeed with a string
            msg["path"] = 42
        return json.dumps(msg, allow_nan=False)
    if kind == 8:                                            # an unknown command, a cmd of the wrong type
        return json.dumps({"cmd": rng.choice([nasty.value(), "SET", "set ", "__init__", "describe\u0000"])})
    return json.dumps({"cmd": rng.choice(["describe", "state", "diff", "modes", "mode_shape", "frames"]),
                       "count": rng.randrange(-2, 300), "lattice": rng.choice(["sheet", "hit", "nothing"]),
                       "mode": rng.randrange(-2, 300), "fps": rng.choice([0, 1, 60, 1e6, -5])})


class Fuzzer:
    """One connection at a time; a closed one is opened again (counted)."""

    def __init__(self, studio, stack):
        self.studio, self.stack, self.ws, self.reopened, self.refused, self.accepted = studio, stack, None, 0, 0, 0
        self.closes = {}
        self.open()

    def open(self):
        if self.ws is not None:
            self.ws.close()
        self.ws = self.stack.enter_context(self.studio.connect(max_queue=None))
        hello(self.ws)

    def answer(self):
        """The next reply (frames and events read past); None if the server closed the socket."""
        try:
            for _ in range(5000):
                msg = self.ws.recv(timeout=120)
                if isinstance(msg, str) and json.loads(msg).get("type") == "reply":
                    return json.loads(msg)
        except ConnectionClosed as exc:
            code = exc.rcvd.code if exc.rcvd else None
            self.closes[code] = self.closes.get(code, 0) + 1
            self.reopened += 1
            self.open()
            return None
        raise AssertionError("no reply")

    def check(self, answer, what):
        assert answer is not None, f"the server closed the connection on {what[:200]!r}"
        if answer["ok"]:
            self.accepted += 1
            return
        self.refused += 1
        assert isinstance(answer["error"], str) and answer["error"] and answer["errors"][0] == answer["error"]
        assert re.match(REFUSAL, answer["error"]), (what[:300], answer["error"][:300])

    def text(self, message):
        self.ws.send(message)
        self.check(self.answer(), message)

    def closing(self, message, text=None):
        """A message the server may close the connection on: it answers with a refusal or closes."""
        self.ws.send(message, text=text)
        answer = self.answer()
        if answer is not None:
            assert not answer["ok"], answer
            self.refused += 1


def flood(ws, count):
    """`count` sets of mic1's gain, each followed by an undo, sent by a thread without waiting for
    their replies, which are read here: each must be accepted. At most IN_FLIGHT wait unanswered:
    the server reads a connection's frames in order, so a pong waits behind the commands sent
    before it, and a connection whose pong is 20 s late is closed (uvicorn's keepalive)."""
    window = threading.Semaphore(IN_FLIGHT)

    def send():
        for i in range(2 * count):
            window.acquire()
            ws.send(json.dumps({"id": i, "cmd": "undo"} if i % 2 else
                               {"id": i, "cmd": "set", "block": "mic1", "param": "gain", "value": 1.0 + i / 1e5}))
    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    for i in range(2 * count):
        answer = reply(ws, i)
        window.release()
        assert answer["ok"], answer
    sender.join(timeout=60)


def non_reading_client(port, token):
    """A WebSocket that completes the handshake and then never reads (a small receive buffer)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.sendall((f"GET /ws?token={token} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = sock.recv(1024)
    assert head.startswith(b"HTTP/1.1 101"), head
    return sock


def test_fuzzed_commands_and_a_flood_of_sets_break_nothing(sheet):
    rng = random.Random(SEED)
    nasty = Nasty(rng)
    before_bytes, before_mtime = sheet.read_bytes(), sheet.stat().st_mtime_ns
    studio = Studio(sheet, preexec_fn=_limit)
    began = time.monotonic()
    stalled = None
    stack = contextlib.ExitStack()
    try:
        fuzz = Fuzzer(studio, stack)
        # warm: every kind of command once, so that what is imported or compiled lazily is in
        for msg in ({"cmd": "set", "block": "mic1", "param": "gain", "value": 1.9}, {"cmd": "modes", "count": 5},
                    {"cmd": "mode_shape", "lattice": "sheet", "mode": 1}, {"cmd": "diff"}, {"cmd": "undo"}):
            fuzz.text(json.dumps(msg))
        stalled = non_reading_client(studio.port, studio.token)     # from here on, reads nothing
        studio.reset_peak()
        rss_before = studio.rss()
        sent = {"text": 0, "binary": 0, "oversized": 0, "not utf-8": 0}
        for i in range(COUNT):
            roll = rng.random()
            if roll < 0.08:
                fuzz.closing(bytes(rng.randrange(256) for _ in range(rng.choice([0, 1, 24, 4096]))))
                sent["binary"] += 1
            elif roll < 0.085:
                fuzz.closing("x" * (MAX_MESSAGE + 1 + rng.randrange(1 << 20)))
                sent["oversized"] += 1
            elif roll < 0.09:
                fuzz.closing(b'{"cmd": "state", "x": "\xff\xfe"}', text=True)
                sent["not utf-8"] += 1
            else:
                fuzz.text(command(rng, nasty))
                sent["text"] += 1
            assert studio.proc.poll() is None, f"the server died at message {i}"
        fuzz_s = time.monotonic() - began
        rss_fuzz_peak = studio.rss("VmHWM")

        # the flood: accepted edits sent without waiting, while the stalled page reads nothing
        fuzz.ws.send(json.dumps({"id": "t", "cmd": "state"}))
        text = reply(fuzz.ws, "t")["result"]["text"]
        studio.reset_peak()
        rss_flood = studio.rss()
        flood_began = time.monotonic()
        flood(fuzz.ws, FLOOD)
        flood_s = time.monotonic() - flood_began
        rss_after, rss_peak = studio.rss(), studio.rss("VmHWM")
        assert time.monotonic() - began < TIME_LIMIT_S

        # still answering, the edits as they were, and the patch file untouched
        fuzz.ws.send(json.dumps({"id": "last", "cmd": "state"}))
        assert reply(fuzz.ws, "last")["result"]["text"] == text
        fuzz.ws.send(json.dumps({"id": "good", "cmd": "set", "block": "mic1", "param": "gain", "value": 1.25}))
        assert reply(fuzz.ws, "good")["ok"]
    finally:
        if stalled is not None:
            stalled.close()
        stack.close()
        code, err = studio.signal(signal.SIGTERM, timeout=60)
    print(f"fuzz: {sum(sent.values())} messages {sent} in {fuzz_s:.1f} s ({fuzz.refused} refused, "
          f"{fuzz.accepted} accepted, connections closed by the server {fuzz.closes}); "
          f"flood: {FLOOD} sets and undos in {flood_s:.1f} s; RSS {rss_before / 2**20:.1f} MiB before, "
          f"{rss_fuzz_peak / 2**20:.1f} after the fuzz, {rss_flood / 2**20:.1f} before the flood, "
          f"peak {rss_peak / 2**20:.1f} during it, {rss_after / 2**20:.1f} after it")
    assert code == 128 + signal.SIGTERM and "Traceback" not in err and "Exception" not in err, err
    assert sheet.read_bytes() == before_bytes and sheet.stat().st_mtime_ns == before_mtime
    assert sorted(p.name for p in sheet.parent.iterdir()) == [".sheet.yaml.studio~", "sheet.yaml"]
    assert fuzz.closes.get(1009, 0) == sent["oversized"] and fuzz.closes.get(1007, 0) == sent["not utf-8"]
    assert fuzz.reopened == sent["oversized"] + sent["not utf-8"]      # nothing else closed a connection
    assert rss_fuzz_peak - rss_before < FUZZ_LIMIT, (rss_before, rss_fuzz_peak)
    assert rss_peak - rss_flood < FLOOD_LIMIT, (rss_flood, rss_peak, rss_after)


def test_connections_beyond_the_limit_are_refused(sheet):
    studio = Studio(sheet)
    try:
        with contextlib.ExitStack() as stack:
            opened = [stack.enter_context(studio.connect()) for _ in range(MAX_CONNECTIONS)]
            for ws in opened:
                hello(ws)
            with pytest.raises(InvalidStatus):
                with studio.connect():
                    pass
            opened[0].close()
            time.sleep(0.5)
            with studio.connect() as ws:                  # a place is free again
                hello(ws)
    finally:
        code, err = studio.signal(signal.SIGTERM, timeout=60)
    assert code == 128 + signal.SIGTERM, err


def test_refusals_say_what_was_wrong(sheet):
    """The same refusals without uvicorn (Starlette's test client): a binary frame, JSON nested
    deeper than Python reads, or than the studio reads (an `id` it would have to write back), a
    message over the limit (uvicorn closes the socket on that one before the studio sees it), a
    `cmd` that is not a name."""
    st = StudioSession(sheet, audio="none").start()
    try:
        with TestClient(build_app(st, "t")).websocket_connect("/ws?token=t") as ws:
            assert ws.receive_json()["type"] == "hello"

            def answer():
                for _ in range(5000):
                    msg = ws.receive()
                    if msg.get("text") and json.loads(msg["text"]).get("type") == "reply":
                        return json.loads(msg["text"])
                raise AssertionError("no reply")
            ws.send_bytes(b"\x01\x02")
            assert answer()["error"].startswith("studio: binary frames carry no command")
            ws.send_text("[" * 100000 + "]" * 100000)
            assert answer()["error"].startswith("studio: not JSON: maximum recursion depth")
            ws.send_text('{"cmd": "state", "id": ' + "[" * 900 + "]" * 900 + "}")
            assert answer()["error"] == "studio: a command nested deeper than 64 levels"
            ws.send_text(json.dumps({"cmd": "text", "text": "x" * MAX_MESSAGE}))
            assert re.match(r"studio: a message of \d+ characters is over the limit", answer()["error"])
            ws.send_text(json.dumps({"cmd": ["set"] * 1000, "id": 5}))
            refused = answer()
            assert refused["id"] == 5 and refused["cmd"] is None
            assert refused["error"].startswith("studio: unknown command a list (one of ")
            ws.send_text(json.dumps({"cmd": "state", "id": 6}))
            assert answer()["ok"]
    finally:
        st.close()


def test_a_slow_page_gets_the_latest_change_and_a_bounded_backlog():
    async def fill():
        box = Mailbox(backlog=8)
        for i in range(100):
            box.put({"type": "changed", "n": i})
            box.put({"type": "problem", "n": i})
        return [await box.get() for _ in range(len(box.items))]
    got = asyncio.run(fill())
    assert [e for e in got if e["type"] == "changed"] == [{"type": "changed", "n": 99}]
    assert [e["n"] for e in got if e["type"] == "problem"] == list(range(92, 100))


def test_probes_are_bounded(sheet, monkeypatch):
    monkeypatch.setattr(commands, "MAX_PROBES", 1)
    st = StudioSession(sheet, audio="none").start()
    try:
        view = commands.View(60)
        assert commands.handle(st, {"cmd": "probe", "signal": "mic1.left"}, view)["ok"]
        refused = commands.handle(st, {"cmd": "probe", "signal": "mic2.left"}, view)
        assert refused["error"] == "studio: probe: 1 signals are probed already (unprobe one first)"
        assert list(st.probes) == ["mic1.left"]
    finally:
        st.close()
