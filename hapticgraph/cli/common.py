"""What the command line's commands share: the usage error (exit status 2), the process's
signals (Interrupt), `--device` choices, the audio channels a patch sends out, and the check every
output path passes before any work (it never names a file the command reads)."""
import contextlib
import inspect
import os
import signal
import sys
import threading


class UsageError(Exception):
    """A command line that cannot be run as given: one `hapticgraph: error:` line, exit status 2."""


AGAIN_SECONDS = 0.01    # after a KeyboardInterrupt was dropped, the signal comes again this much later


class Interrupt:
    """The signals of a command's process: SIGINT from the first line of `main` to the process's
    end, SIGTERM and SIGHUP while a command asks (`take`). Every command finds it as
    `args.interrupt`.

    The first signal raises KeyboardInterrupt where the program is, as Python's own handler does
    — unless the command is running its patch (`rendering`: the signal is then a request, which
    the command reads as `signum` at its next block; graph.engine.stream does) or is inside
    `held()` (raised at its end: a temporary file and the code that removes it are never
    separated). Every later signal is only noted, so that no clean-up is cut short. `signum` is
    the first signal received, `raised` True once KeyboardInterrupt was raised for it; `status()`
    the exit status it gives (128 + its number: 130 for Ctrl-C, as a shell reports it).

    Once the command has finished — its files closed, its output flushed — `finished(status)`:
    a signal then ends the process at once with that status (os._exit), so that the
    interpreter's own ending (joining threads, collecting garbage) is never interrupted and can
    print no "Exception ignored". A KeyboardInterrupt raised where no exception can leave (a
    weakref callback, a `__del__`: Python would print "Exception ignored" and drop it) is dropped
    silently and the signal sent again a moment later (AGAIN_SECONDS), to be raised elsewhere;
    any other exception a `__del__` raises once a signal came is dropped too.
    Signals reach the main thread only: elsewhere `take` does nothing; a signal ignored by whoever
    started the process (`hapticgraph run … &` in a script) stays ignored."""

    def __init__(self):
        self.signum = None
        self.rendering = False
        self.raised = False
        self._held = 0
        self._previous = {}
        self._status = None
        self._hook = None             # sys.unraisablehook found by the first `take`
        self._exit = os._exit         # bound now: at the interpreter's end module globals may be gone

    def take(self, *signums):
        """Handle these signals (as above) until `give_back`."""
        if threading.current_thread() is not threading.main_thread():
            return
        for signum in signums:
            if signum not in self._previous and signal.getsignal(signum) is not signal.SIG_IGN:
                self._previous[signum] = signal.signal(signum, self.request)
        if self._previous and self._hook is None:
            self._hook, sys.unraisablehook = sys.unraisablehook, self._unraisable

    def give_back(self):
        """The handlers found by `take`, put back."""
        while self._previous:
            signum, handler = self._previous.popitem()
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        if self._hook is not None:
            sys.unraisablehook, self._hook = self._hook, None

    def _unraisable(self, unraisable):
        if self.signum is not None and not issubclass(unraisable.exc_type, KeyboardInterrupt):
            # after an interrupt, an object it left half-made complains as it is dropped (llvmlite's
            # __del__ of a pass-manager option interrupted in its __init__): not news to the user
            return
        if not (issubclass(unraisable.exc_type, KeyboardInterrupt) and self.raised and self._previous):
            self._hook(unraisable)
            return
        self._held += 1               # a signal now is only noted: nothing may leave this hook
        try:
            self.raised = False       # dropped: the signal comes again once this hook has returned
            again = threading.Timer(AGAIN_SECONDS, self._again)
            again.daemon = True
            again.start()
        finally:
            self._held -= 1

    def _again(self):
        if self.signum in self._previous:
            signal.pthread_kill(threading.main_thread().ident, self.signum)

    def request(self, signum, frame=None):
        """The signal handler."""
        if self._status is not None:
            self._exit(self._status)
        if self.signum is None:
            self.signum = signum
        self._raise()

    def _raise(self):
        if self.signum is not None and not (self.raised or self.rendering or self._held):
            self.raised = True
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def held(self):
        """A section no signal cuts: one received inside is raised at its end (if it ends
        normally; an exception leaving it goes on instead)."""
        self._held += 1
        try:
            yield
        finally:
            self._held -= 1
        self._raise()

    def status(self):
        """The exit status of a process ended by the signal received (Ctrl-C if none was)."""
        return 128 + (self.signum if self.signum is not None else signal.SIGINT)

    def finished(self, status):
        """The command is done and its output flushed: a signal from now on exits with `status`."""
        self._status = status

    def settle(self):
        """Every signal taken is ignored from now on: for the interpreter's last moments, after
        its exit functions (`main` registers this one first, so that it runs last), when Python
        gives up its handlers and a signal would kill a process whose work is done."""
        for signum in self._previous:
            signal.signal(signum, signal.SIG_IGN)


def device_choices(items):
    """`--device NAME=DRIVER[,KEY=VALUE...]` -> {name: Choice}; a bad one is a UsageError that
    says what the driver accepts."""
    if not items:
        return {}
    from ..devices import DeviceError, parse_choice
    choices = {}
    for item in items:
        try:
            name, choice = parse_choice(item)
        except DeviceError as exc:
            raise UsageError(str(exc)) from None
        if name in choices:
            raise UsageError(f"--device {item!r}: device {name!r} is given twice")
        choices[name] = choice
    return choices


def audio_channels(patch):
    """The channels of the patch's audio sink (0: it has none)."""
    for inst in patch.blocks.values():
        if getattr(inst.cls, "audio_sink", False):
            return len(inst.inputs)
    return 0


def input_files(patch, replay=None):
    """Every file a command on `patch` reads: the patch, its plugin files and block modules,
    audio_in files, the files its devices name (a profile, a MIDI file...), the take replayed."""
    base = os.path.dirname(os.path.abspath(patch.file))
    files = [patch.file, *patch.registry.plugin_files]
    plugins = patch.doc.get("plugins") if isinstance(patch.doc, dict) else None
    files += [os.path.join(base, p) for p in plugins or () if isinstance(p, str) and p.endswith(".py")]
    for inst in patch.blocks.values():
        try:
            files.append(inspect.getfile(inst.cls))
        except (TypeError, OSError):
            pass
        files += [os.path.join(base, inst.values[n]) for n, p in inst.cls.params.items()
                  if p.refers == "file" and inst.values.get(n)]
    for spec in patch.devices.values():       # any setting naming a file beside the patch
        if isinstance(spec, dict):
            files += [os.path.join(base, v) for v in spec.values()
                      if isinstance(v, str) and v and os.path.isfile(os.path.join(base, v))]
    if replay:
        from ..devices.take import take_paths
        files += [replay, *take_paths(replay)]
    return files


def same_file(a, b):
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_output(option, path, inputs, command="run"):
    """Refuse, before any work, an output that would overwrite an input (`inputs`, see
    input_files) or cannot be written; returns the path to write (a symbolic link is written
    through)."""
    for used in inputs:
        if same_file(path, used):
            raise UsageError(f"{option} {os.fspath(path)!r} is a file this {command} reads "
                             f"({os.path.basename(used)}); choose another name")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise UsageError(f"{option} {path!r}: the folder {os.path.dirname(path) or '.'!r} does not exist")
    if os.path.lexists(path):
        if os.path.isdir(path):
            raise UsageError(f"{option} {path!r} is a folder")
        if not os.path.isfile(path):
            raise UsageError(f"{option} {path!r} exists and is not a regular file (a device or a pipe)")
        path = os.path.realpath(path)
    if not os.access(os.path.dirname(os.path.abspath(path)), os.W_OK | os.X_OK):
        raise UsageError(f"{option} {path!r}: the folder is not writable")
    return path
