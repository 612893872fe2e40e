"""`hapticgraph studio` as a child process on loopback for the recovery and fuzz tests: started
with --no-browser --audio none, its URL and token read from the first line, talked to over a real
WebSocket (the websockets client), stopped by its PID. Every wait has a deadline."""
import json
import os
import re
import select
import signal
import subprocess
import sys
import threading

from websockets.sync.client import connect

FIRST_LINE = re.compile(r"hapticgraph studio: http://127\.0\.0\.1:(\d+)/\?token=([A-Za-z0-9_\-]{20,})\n")
START_S = 120          # importing, loading and compiling the patch on a loaded machine
REPLY_LIMIT = 5000     # messages read past (frames, events) while waiting for one reply


class Studio:
    """A running `hapticgraph studio PATH`: .port, .token, .proc, .page (its URL); .connect() a WebSocket."""

    def __init__(self, path, *args, preexec_fn=None):
        self.proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "studio", str(path), "--no-browser",
                                      "--audio", "none", *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=preexec_fn)
        ready, _, _ = select.select([self.proc.stdout], [], [], START_S)
        line = self.proc.stdout.readline() if ready else ""
        m = FIRST_LINE.fullmatch(line)
        if m is None:
            self.kill()
            raise AssertionError(f"no first line from the studio ({line!r}): {self.proc.stderr.read()}")
        # drained all along: a pipe left full would stop the server at its next line of log
        self.err = []
        self.drains = [threading.Thread(target=lambda: self.err.append(self.proc.stderr.read()), daemon=True),
                       threading.Thread(target=self.proc.stdout.read, daemon=True)]
        for t in self.drains:
            t.start()
        self.port, self.token = int(m.group(1)), m.group(2)
        self.url = f"ws://127.0.0.1:{self.port}/ws?token={self.token}"
        self.page = f"http://127.0.0.1:{self.port}/?token={self.token}"

    def connect(self, **kwargs):
        return connect(self.url, open_timeout=10, max_size=None, **kwargs)

    def rss(self, field="VmRSS"):
        """The server's resident memory [bytes]: now (VmRSS) or at its peak so far (VmHWM)."""
        with open(f"/proc/{self.proc.pid}/status") as f:
            for line in f:
                if line.startswith(f"{field}:"):
                    return int(line.split()[1]) * 1024
        raise AssertionError(f"no {field}")

    def reset_peak(self):
        """VmHWM set back to VmRSS (Linux: clear_refs), so that the peak measures from now."""
        with open(f"/proc/{self.proc.pid}/clear_refs", "w") as f:
            f.write("5")

    def signal(self, signum, timeout=30):
        """Send `signum`; (exit status, standard error) once it has ended."""
        os.kill(self.proc.pid, signum)
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f"the studio did not end on signal {signum}") from None
        return self.proc.returncode, self.stderr()

    def stderr(self):
        """Its standard error, once it has ended."""
        for t in self.drains:
            t.join(timeout=30)
        return "".join(self.err)

    def kill(self):
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=30)


def hello(ws):
    """The first message: the hello event."""
    obj = json.loads(ws.recv(timeout=60))
    assert obj["type"] == "hello", obj
    return obj


def next_event(ws, kind, limit=REPLY_LIMIT):
    for _ in range(limit):
        msg = ws.recv(timeout=60)
        if isinstance(msg, str):
            obj = json.loads(msg)
            if obj.get("type") == kind:
                return obj
    raise AssertionError(f"no {kind} event")


def reply(ws, ident, limit=REPLY_LIMIT, events=None):
    """The reply to command `ident` (frames and events read past; events kept in `events`)."""
    for _ in range(limit):
        msg = ws.recv(timeout=120)
        if isinstance(msg, str):
            obj = json.loads(msg)
            if obj.get("type") == "reply" and obj.get("id") == ident:
                return obj
            if events is not None and obj.get("type") != "reply":
                events.append(obj)
    raise AssertionError(f"no reply to {ident}")


class Script:
    """Commands with ids over one WebSocket."""

    def __init__(self, ws):
        self.ws, self.next_id, self.events = ws, 0, []

    def send(self, cmd, **fields):
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "cmd": cmd, **fields}))
        return reply(self.ws, self.next_id, events=self.events)

    def ok(self, cmd, **fields):
        answer = self.send(cmd, **fields)
        assert answer["ok"], answer
        return answer["result"]
