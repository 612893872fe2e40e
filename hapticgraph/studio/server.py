"""The studio's web server (Starlette, served by uvicorn): the page, its files and the WebSocket of
docs/studio.md.

Every HTTP request needs the token (`?token=T`, or the cookie the page's own response sets);
the WebSocket needs `?token=T` and, from a browser, an Origin that is the studio's own. Whatever
a connection sends, it gets a reply or its socket is closed, and what the server keeps for it is
bounded: one message of at most MAX_MESSAGE in, the latest `changed` event and EVENT_BACKLOG
others out, MAX_CONNECTIONS connections at once.
"""
import asyncio
import collections
import contextlib
import json
import logging
import math
import os
import secrets
import signal
from http.cookies import SimpleCookie
from urllib.parse import parse_qs

import uvicorn
from starlette.applications import Starlette
from starlette.responses import FileResponse, PlainTextResponse
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocketDisconnect

from .commands import View, handle

STATIC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "static")
COOKIE = "hapticgraph_studio_token"
LOOPBACK = ("127.0.0.1", "localhost", "[::1]")
STATUS_EVERY = 1.0
STREAM_POLL = 0.01         # seconds between looks for audio and probe frames while some flow
IDLE_POLL = 0.1            # ... while none do (each look takes the GIL from the sound thread)
MAX_MESSAGE = 1 << 20      # bytes of one message from a client (a patch's text is kilobytes): more closes it (1009)
MAX_CONNECTIONS = 16       # WebSockets at once; more are refused (HTTP 403) until one closes
EVENT_BACKLOG = 64         # events other than `changed` waiting for a slow connection; the oldest go first
MAX_DEPTH = 64             # lists and objects in one another in a command (a patch's deepest is ~5): what
                           # reads it, writes it back (the `id`) or quotes it then never recurses too deep


def new_token():
    return secrets.token_urlsafe(24)


def _query_token(scope):
    values = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [])
    return values[0] if values else None


def _header(scope, name):
    for k, v in scope.get("headers", ()):
        if k.decode("latin-1").lower() == name:
            return v.decode("latin-1")
    return None


def _cookie_token(scope):
    raw = _header(scope, "cookie")
    if not raw:
        return None
    jar = SimpleCookie()
    try:
        jar.load(raw)
    except Exception:  # noqa: BLE001 - a malformed cookie header is no token
        return None
    return jar[COOKIE].value if COOKIE in jar else None


class Guard:
    """ASGI middleware: the token on every request, the Origin on the WebSocket."""

    def __init__(self, app, token, host):
        self.app, self.token, self.host = app, token, host

    def _token_ok(self, given):
        return isinstance(given, str) and secrets.compare_digest(given.encode(), self.token.encode())

    def origin_ok(self, scope):
        origin = _header(scope, "origin")
        if origin is None:
            return True                        # not a browser: the token is enough
        port = scope.get("server", (None, None))[1]
        names = set(LOOPBACK) | {self.host if ":" not in self.host else f"[{self.host}]"}
        allowed = {f"http://{n}:{port}" for n in names}
        if self.host not in ("127.0.0.1", "localhost", "::1"):
            allowed.add(f"http://{_header(scope, 'host')}")     # told to serve other machines
        return origin in allowed

    async def __call__(self, scope, receive, send):
        kind = scope["type"]
        if kind == "websocket":
            if not (self._token_ok(_query_token(scope)) and self.origin_ok(scope)):
                await send({"type": "websocket.close", "code": 1008})
                return
        elif kind == "http":
            if not (self._token_ok(_query_token(scope)) or self._token_ok(_cookie_token(scope))):
                await PlainTextResponse("hapticgraph studio: a token is needed (open the URL the studio printed)",
                                        status_code=403)(scope, receive, send)
                return
        await self.app(scope, receive, send)


def build_app(studio, token, host="127.0.0.1", start=False):
    """The ASGI app serving `studio` (a StudioSession) behind the token; `start`: the app's
    lifespan starts the sound once the server is up (its imports and set-up then no longer
    compete with the first blocks for the interpreter)."""
    async def page(request):
        index = os.path.join(STATIC, "index.html")
        if not os.path.isfile(index):
            return PlainTextResponse("hapticgraph studio: the page's files are not installed "
                                     "(hapticgraph/studio/static/index.html)", status_code=404)
        response = FileResponse(index, headers={"Cache-Control": "no-store"})
        response.set_cookie(COOKIE, token, httponly=True, samesite="strict", path="/")
        return response

    open_now = []

    async def socket(websocket):
        if len(open_now) >= MAX_CONNECTIONS:
            await websocket.close(code=1013)          # before the handshake: HTTP 403
            return
        open_now.append(websocket)
        try:
            await Connection(studio, websocket).run()
        finally:
            open_now.remove(websocket)

    async def missing(request):
        return PlainTextResponse("hapticgraph studio: the page's files are not installed", status_code=404)

    files = (Mount("/static", app=StaticFiles(directory=STATIC), name="static") if os.path.isdir(STATIC)
             else Route("/static/{path:path}", missing))
    async def icon(request):          # what a browser asks for when a page names no icon
        svg = os.path.join(STATIC, "favicon.svg")
        if not os.path.isfile(svg):
            return await missing(request)
        return FileResponse(svg, media_type="image/svg+xml")

    routes = [Route("/", page), Route("/favicon.ico", icon), WebSocketRoute("/ws", socket), files]

    @contextlib.asynccontextmanager
    async def lifespan(app):
        if start:
            studio.start()
        yield
    return Guard(Starlette(routes=routes, lifespan=lifespan), token, host)


def _finite(obj):
    """`obj` with every NaN or infinite float replaced by None."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


class Mailbox:
    """The events waiting to be sent on one connection. A `changed` event replaces one not yet
    sent (each is the whole instrument: a page that is behind needs only the latest); of the
    others at most `backlog` wait, the oldest dropped first. So a page that reads slowly, or not
    at all, costs the server a bounded amount however many edits are made."""

    LATEST = "changed"

    def __init__(self, backlog=EVENT_BACKLOG):
        self.items, self.backlog, self.ready = collections.deque(), backlog, asyncio.Event()

    def put(self, event):
        if event.get("type") == self.LATEST:
            for old in [e for e in self.items if e.get("type") == self.LATEST]:
                self.items.remove(old)
        self.items.append(event)
        others = [e for e in self.items if e.get("type") != self.LATEST]
        for old in others[:max(0, len(others) - self.backlog)]:
            self.items.remove(old)
        self.ready.set()

    async def get(self):
        while not self.items:
            self.ready.clear()
            await self.ready.wait()
        return self.items.popleft()


def _depth(value):
    """How deeply lists and dicts nest in `value` (0 for a scalar), without recursion."""
    deepest, todo = 0, [(value, 0)]
    while todo:
        v, d = todo.pop()
        if isinstance(v, dict):
            v = v.values()
        elif not isinstance(v, list):
            deepest = max(deepest, d)
            continue
        deepest = max(deepest, d + 1)
        if d + 1 > MAX_DEPTH:
            return d + 1
        todo.extend((x, d + 1) for x in v)
    return deepest


def refusal(error, ident=None):
    return {"type": "reply", "id": ident, "cmd": None, "ok": False, "error": error, "errors": [error]}


class Connection:
    """One WebSocket: commands in, replies, events and frames out (one send at a time)."""

    def __init__(self, studio, websocket):
        self.studio, self.ws = studio, websocket
        self.view = View(studio.fps)
        self.events = Mailbox()
        self.sending = asyncio.Lock()

    async def send_json(self, obj):
        try:
            text = json.dumps(obj, allow_nan=False, default=float)
        except ValueError:                     # a NaN or an infinity: null, which JSON has
            text = json.dumps(_finite(obj), allow_nan=False, default=float)
        async with self.sending:
            await self.ws.send_text(text)

    async def send_bytes(self, data):
        async with self.sending:
            await self.ws.send_bytes(data)

    async def run(self):
        await self.ws.accept()
        loop = asyncio.get_running_loop()

        def listener(event):
            loop.call_soon_threadsafe(self.events.put, event)
        hello, offer = await asyncio.to_thread(self._welcome, listener)
        tasks = []
        try:
            await self.send_json({**hello, "type": "hello"})
            if offer is not None:
                await self.send_json(offer)
            tasks = [asyncio.create_task(t) for t in (self._events(), self._frames(), self._streams(), self._status())]
            await self._commands()
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            self.studio.listeners.remove(listener)
            for t in tasks:
                t.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

    def _welcome(self, listener):
        """The hello, the recovery offer (or None) and the listener registered, at one moment:
        every event after the hello reaches this connection, none before it."""
        with self.studio.lock:
            hello, offer = self.studio.describe(), self.studio.offer
            event = None if offer is None else offer.event()
            self.studio.listeners.append(listener)
            return hello, event

    async def _commands(self):
        while True:
            message = await self.ws.receive()
            if message["type"] == "websocket.disconnect":
                raise WebSocketDisconnect(message.get("code", 1000))
            msg, refused = self._parse(message)
            if refused is not None:
                await self.send_json(refused)
                continue
            reply = await asyncio.to_thread(handle, self.studio, msg, self.view)
            await self.send_json(reply)

    @staticmethod
    def _parse(message):
        """(the command object, None) or (None, the reply refusing it)."""
        text = message.get("text")
        if text is None:
            return None, refusal("studio: binary frames carry no command: send a command as a JSON text frame")
        if len(text) > MAX_MESSAGE:
            return None, refusal(f"studio: a message of {len(text)} characters is over the limit ({MAX_MESSAGE})")
        try:
            msg = json.loads(text)
        except (ValueError, RecursionError) as exc:   # RecursionError: nested deeper than Python reads
            return None, refusal(f"studio: not JSON: {exc}")
        if _depth(msg) > MAX_DEPTH:
            return None, refusal(f"studio: a command nested deeper than {MAX_DEPTH} levels")
        return msg, None

    async def _events(self):
        while True:
            await self.send_json(await self.events.get())

    async def _frames(self):
        """The latest cell frame, at most view.fps a second; frames made while one was being
        sent are skipped, never queued."""
        tap, sent = self.studio.tap, 0
        while True:
            fps = self.view.fps
            await asyncio.sleep(1.0 / fps if fps > 0 else 0.2)
            frame = tap.frame
            if self.view.fps <= 0 or frame is None or frame[0] == sent:
                continue
            sent = frame[0]
            wanted = self.view.lattices
            for i, data in enumerate(frame[1]):
                if wanted is None or i in wanted:
                    await self.send_bytes(data)

    async def _streams(self):
        """Audio and probe frames, in order; the poll slows down while there are none."""
        tap, seq = self.studio.tap, 0
        while True:
            await asyncio.sleep(STREAM_POLL if tap.streaming() else IDLE_POLL)
            for seq, data in tap.since(seq):
                await self.send_bytes(data)

    async def _status(self):
        while True:
            await asyncio.sleep(STATUS_EVERY)
            await self.send_json(self.studio.status())


class ClientFaults(logging.Filter):
    """uvicorn logs a text frame that is not UTF-8 (its client's fault, closed with 1007) with a
    traceback: one line is enough, as a warning."""

    def filter(self, record):
        if record.exc_info and isinstance(record.exc_info[1], UnicodeDecodeError):
            record.exc_info, record.exc_text = None, None
            record.levelno, record.levelname = logging.WARNING, "WARNING"
        return True


class Server(uvicorn.Server):
    """uvicorn's server, which notes the signal that stops it (`stopped_by`): once the user has
    asked it to stop, what uvicorn would still log (a page that does not answer the close in
    time) is no news, and the one line the studio prints then says everything."""

    stopped_by = None

    def handle_exit(self, sig, frame):
        if self.stopped_by is None:
            self.stopped_by = signal.Signals(sig)
            logging.getLogger("uvicorn.error").setLevel(logging.CRITICAL)
        super().handle_exit(sig, frame)


def serve(studio, token, sock, host="127.0.0.1"):
    """Serve `studio` on the listening socket `sock` until SIGINT or SIGTERM; the signal that
    stopped it (a signal.Signals), or None."""
    logging.getLogger("uvicorn.error").addFilter(ClientFaults())
    server = Server(uvicorn.Config(build_app(studio, token, host, start=True), log_level="warning", lifespan="on",
                                   timeout_graceful_shutdown=2, ws_max_size=MAX_MESSAGE))
    server.run(sockets=[sock])
    return server.stopped_by
