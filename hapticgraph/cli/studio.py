"""`hapticgraph studio PATCH`: load the patch, start its sound, serve the page (uvicorn) and print
its URL with the token as the first line on standard output."""
import os
import signal
import socket
import sys
import threading
import webbrowser

from .common import UsageError, audio_channels, device_choices
from ..devices import DeviceError, check_choices
from ..graph.patch import load
from ..studio.recovery import edits_text
from ..studio.server import new_token, serve
from ..studio.session import StudioSession


SWITCH = 0.0002     # seconds a thread keeps the GIL while another waits: the sound thread waits less


def _check(args):
    if not 0 <= args.port <= 65535:
        raise UsageError(f"--port {args.port}: expected 0 (any free port) to 65535")
    if not 1 <= args.blocksize <= 1 << 15:
        raise UsageError(f"--blocksize {args.blocksize}: expected a number of samples from 1 to 32768")
    if not 0 < args.fps <= 240:
        raise UsageError(f"--fps {args.fps:g}: expected frames per second in (0, 240]")


def _bind(host, port):
    """A listening socket on host:port (port 0: any free one)."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise UsageError(f"--host {host!r}: {exc.strerror or exc}") from None
    family, kind, proto, _, address = infos[0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(64)
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot serve on {host}:{port}: {exc.strerror or exc}") from None
    return sock


def _audio_device(args, patch):
    """The output device with --audio card; without --audio, the sound card when one opens,
    else the page plays the sound (a headless or remote machine): args.audio is set to what runs."""
    if args.audio not in (None, "card"):
        if args.audio_device:
            raise UsageError("--audio-device goes with --audio card")
        return None
    from ..devices import audio
    try:
        audio.sounddevice()
        device = audio.find_device(args.audio_device, "output", max(1, audio_channels(patch)))
    except audio.AudioError as exc:
        if args.audio == "card":
            raise UsageError(f"{exc} (--audio browser plays in the page, --audio none is silent)") from None
        print(f"hapticgraph: note: no sound card ({exc}); the sound plays in the page (--audio browser)",
              file=sys.stderr)
        args.audio = "browser"
        return None
    args.audio = "card"
    return device


def _quiet(signum, frame):
    pass


def _note(message):
    print(f"hapticgraph: note: {message}", file=sys.stderr, flush=True)


def _stopped(studio, signum):
    """The one line said when the studio stops: by what, and where its unsaved edits are."""
    line = "hapticgraph: studio stopped" + (f" ({signum.name})" if signum is not None else "")
    kept = studio.kept()
    if kept is not None:
        edits, file = kept
        line += (f"; {edits_text(edits)} kept in {file}, offered when the studio opens "
                 f"{os.path.basename(studio.path)} again")
    return line


def cmd_studio(args):
    _check(args)
    choices = device_choices(args.device)
    patch = load(args.patch)
    try:
        check_choices(patch, choices)
    except DeviceError as exc:
        raise UsageError(str(exc)) from None
    device = _audio_device(args, patch)
    sock = _bind(args.host, args.port)
    studio = StudioSession(args.patch, audio=args.audio, choices=choices, blocksize=args.blocksize,
                           fps=args.fps, device=device, note=_note)
    token = new_token()
    port = sock.getsockname()[1]
    host = f"[{args.host}]" if ":" in args.host else args.host
    url = f"http://{host}:{port}/?token={token}"
    print(f"hapticgraph studio: {url}", flush=True)
    print(f"hapticgraph: studio of {patch.name!r} ({args.audio} audio); Ctrl-C stops it", file=sys.stderr)
    sys.setswitchinterval(SWITCH)
    if not args.no_browser:
        threading.Timer(0.3, webbrowser.open, (url,)).start()
    # uvicorn stops gracefully on SIGINT/SIGTERM, then raises the signal again under the handler
    # found before it: a quiet one, so that the studio closes its sound and says one line; the
    # status is a signal's (130 for Ctrl-C, 143 for SIGTERM) as for every command; the recovery
    # file stays for the next studio
    previous = {sig: signal.signal(sig, _quiet) for sig in (signal.SIGINT, signal.SIGTERM)}
    stopped_by = None
    try:
        stopped_by = serve(studio, token, sock, args.host)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        studio.close()
        sock.close()
    print(_stopped(studio, stopped_by), file=sys.stderr, flush=True)
    return 0 if stopped_by is None else 128 + stopped_by
