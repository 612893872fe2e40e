"""The studio's state: the patch text being edited (with undo and redo), the patch it loads to,
and the sound running it. Every edit is a new text that goes through the loader first; then it
reaches the running sound (live parameters set, anything else swapped in keeping state) and
only then becomes the text, kept in the recovery file until it is saved (recovery.py).
Commands are run one at a time (`lock`)."""
import difflib
import os
import sys
import threading
import time

from ..devices import DeviceError
from ..graph.errors import PatchError
from ..graph.patch import load
from . import adapter, recovery
from .describe import describe
from .runner import CardRunner, ClockRunner
from .tap import Tap

VERSION = 1
SWAP_TIMEOUT = 120.0       # seconds a compiled swap may wait for the sound thread (a loaded machine)
RECHECK_BLOCKS = 2         # blocks an edit after a safety stop must play before its state is trusted
RECHECK_SECONDS = 2.0      # ... at most this long (a loaded machine, a sound card opening again)
UNDO_BYTES = 16 << 20      # memory of the texts the undo history holds; beyond it the oldest go (a flood of edits)


class CommandError(Exception):
    """A refused command: `errors` as the page shows them (FILE:LINE: message, or studio: ...)."""

    def __init__(self, errors):
        self.errors = list(errors)
        super().__init__(self.errors[0])


def read_file(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


class StudioSession:
    """One patch file open in the studio. `audio`: card | browser | none; `note(message)` is told
    what the user should know about the recovery file (an offer of unsaved edits, one not
    offered, one that cannot be written)."""

    PlanError = adapter.PlanError

    def __init__(self, path, audio="none", choices=None, blocksize=256, fps=60, device=None, note=None):
        self.path = os.fspath(path)
        self.saved = read_file(self.path)
        self.text = self.saved
        self.patch = load(self.path, text=self.text)          # PatchError: the CLI exits 2
        self.audio, self.choices, self.blocksize, self.fps = audio, dict(choices or {}), int(blocksize), fps
        self.undo_stack, self.redo_stack, self.undo_bytes = [], [], 0
        self.note = note if note is not None else (lambda message: None)
        self.unsaved = 0             # accepted edits (undo and redo too) since the text was the file's
        self.unkept = None           # why the last edit could not be kept in the recovery file
        self.gesture = None          # the gesture of the last edit (docs/studio.md: set)
        self.offer = recovery.find(self.path, self.saved, self.note)
        self.probes = {}
        self.problem = None
        self.lock = threading.RLock()
        self.listeners = []
        self.tap = Tap(fps, audio=(audio == "browser"))
        self.live = adapter.Live(adapter.open_session(self.patch, self.blocksize, devices=self.choices))
        if audio == "card":
            self.runner = CardRunner(self.live, self.tap, self._on_problem, device=device, blocksize=self.blocksize)
        else:
            self.runner = ClockRunner(self.live, self.tap, self._on_problem)

    def start(self):
        self.runner.start()
        return self

    def close(self):
        self.runner.stop()
        self.live.session.close()

    # -- events --------------------------------------------------------------------------------
    def _emit(self, event):
        for listener in list(self.listeners):
            listener(event)

    def _on_problem(self, message):
        self.problem = message
        self._emit({"type": "problem", "message": message})

    def describe(self):
        d = describe(self.patch, self.text)
        kept = self.kept()
        d.update(version=VERSION, fps=self.fps, dirty=self.text != self.saved, undo=len(self.undo_stack),
                 redo=len(self.redo_stack), problem=self.problem,
                 kept=None if kept is None else {"edits": kept[0], "file": kept[1]},
                 audio={"mode": self.audio, "rate": self.patch.rate, "blocksize": self.blocksize,
                        "channels": self.live.session.channels})
        return d

    def status(self):
        return {"type": "status", "t": self.live.t / self.live.rate, "xruns": self.runner.xruns,
                "load": self.runner.load}

    # -- errors ---------------------------------------------------------------------------------
    def where(self, block, message):
        """`FILE:LINE: message` at the block's line when the patch has that block."""
        inst = self.patch.blocks.get(block) if isinstance(block, str) else None
        if inst is None:
            return f"studio: {message}"
        return f"{self.path}:{inst.line}: {message}"

    # -- edits ----------------------------------------------------------------------------------
    def load_text(self, text):
        try:
            return load(self.path, text=text)
        except PatchError as exc:
            raise CommandError([str(p) for p in exc.problems] or [str(exc)]) from None

    def change(self, text, cause, block=None, gesture=None):
        """Make `text` the patch: loaded, then applied to the sound, then kept (undo history).
        `gesture`: edits with the same one in a row (a slider's drag) are one undo entry."""
        self.answered()
        if text == self.text:
            return
        patch = self.accept(text, block)
        going_on = gesture is not None and gesture == self.gesture and bool(self.undo_stack)
        if not going_on:
            self.remember(self.text)
        self.gesture = gesture
        self.commit(text, patch, cause, edits=self.unsaved if going_on else None)

    def remember(self, text):
        """`text` onto the undo history (the oldest dropped beyond UNDO_BYTES); no redo after a new edit."""
        self.undo_stack.append(text)
        self.undo_bytes += sys.getsizeof(text)
        while self.undo_bytes > UNDO_BYTES and len(self.undo_stack) > 1:
            self.undo_bytes -= sys.getsizeof(self.undo_stack.pop(0))
        self.redo_stack.clear()

    def accept(self, text, block=None):
        """The patch of `text`, applied to the running sound; CommandError (nothing changed) if
        the loader or the running program refuses it."""
        patch = self.load_text(text)
        try:
            self.apply(patch)
        except (adapter.PlanError, ValueError, DeviceError) as exc:
            raise CommandError([self.where(block, str(exc))]) from None
        return patch

    def commit(self, text, patch, cause, edits=None):
        self.text, self.patch = text, patch
        self.keep(edits)
        self._emit({**self.describe(), "type": "changed", "cmd": cause})

    # -- unsaved edits --------------------------------------------------------------------------
    def keep(self, edits=None):
        """The text into the recovery file after an accepted edit (`edits`: the count it stands
        for, default one more); the file removed when the text is the file's again."""
        if self.text == self.saved:
            self.unsaved = 0
            recovery.remove(self.path)
            return
        self.unsaved = self.unsaved + 1 if edits is None else edits
        try:
            recovery.write(self.path, self.text, self.saved, self.unsaved)
        except OSError as exc:
            unkept = f"cannot keep the unsaved edits in {recovery.path_of(self.path)}: {exc.strerror or exc}"
            if unkept != self.unkept:
                self.note(unkept)
            self.unkept = unkept
        else:
            self.unkept = None

    def answered(self):
        """CommandError while unsaved edits of an earlier studio are offered: an edit or a save
        now would replace them."""
        if self.offer is not None:
            raise CommandError([f"studio: {recovery.edits_text(self.offer.edits)} of an earlier studio are "
                                f"offered ({self.offer.file}): recover them, or discard_recovery, first"])

    def recover(self):
        """The offered text made the patch (through the loader and the sound, as any edit)."""
        offer = self.offer
        if offer is None:
            raise CommandError(["studio: recover: no unsaved edits are offered"])
        patch = self.accept(offer.text)
        self.offer = None
        self.gesture = None
        self.remember(self.text)
        self.commit(offer.text, patch, "recover", edits=offer.edits)
        self._emit({"type": "recovery", "offered": False, "cmd": "recover"})
        return {"edits": offer.edits, "undo": len(self.undo_stack), "redo": len(self.redo_stack)}

    def discard_recovery(self):
        if self.offer is None:
            raise CommandError(["studio: discard_recovery: no unsaved edits are offered"])
        self.offer = None
        recovery.remove(self.path)
        self._emit({"type": "recovery", "offered": False, "cmd": "discard_recovery"})
        return {}

    def kept(self):
        """(edits, file) of the recovery file as this studio leaves it, or None."""
        if self.offer is not None:
            return self.offer.edits, self.offer.file
        if self.unsaved and self.unkept is None:
            return self.unsaved, recovery.path_of(self.path)
        return None

    def apply(self, patch):
        """To the running sound: live parameters when only they changed, else a swap. After a
        safety stop (a runaway, a NaN) the swap keeps the state and the clock as any other; if
        that state runs away again at once, the patch starts from rest (undo back to a stable
        patch then plays again: the sound does not stay stopped)."""
        stopped = self.runner.problem is not None
        changes = adapter.live_changes(self.patch, patch)
        if changes is not None and not stopped:
            adapter.apply_live(self.live.session, changes)
            return
        since = self.live.t
        self.swap(patch)
        if stopped and self._stops_again(since):
            self.restart(patch)

    def _stops_again(self, since):
        """True if the sound stops again (a safety stop) before it has played RECHECK_BLOCKS
        blocks past sample `since`, within RECHECK_SECONDS."""
        deadline = time.monotonic() + RECHECK_SECONDS
        while time.monotonic() < deadline:
            if self.runner.problem is not None:
                return True
            if self.live.t >= since + RECHECK_BLOCKS * self.blocksize:
                return False
            time.sleep(0.005)
        return self.runner.problem is not None

    def swap(self, patch, probes=None):
        """Compile `patch` (the old one keeps playing meanwhile) and swap it in, keeping state."""
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, 0.0002))       # let the sound thread in while compiling
        try:
            queued = adapter.swap(self.live, patch, probes)
        finally:
            sys.setswitchinterval(switch)
        self.runner.resume()
        if not self._taken(queued):
            raise adapter.PlanError("the sound did not take the edit (it has stopped); nothing changed")
        self.problem = None

    def _taken(self, queued):
        """Wait for the sound thread's next block boundary, however loaded the machine (the
        compile is done already): True once the swap plays; False if the sound stopped or
        after SWAP_TIMEOUT (the swap is withdrawn then)."""
        deadline = time.monotonic() + SWAP_TIMEOUT
        while time.monotonic() < deadline:
            if queued.applied.wait(0.05):
                return queued.wait(0)
            if self.runner.problem is not None and self.audio == "card" and self.runner.player is None:
                break
        return queued.wait(0)

    def restart(self, patch=None):
        """The patch (the current one, or `patch`) from rest at t = 0; the sound on again."""
        adapter.restart(self.live, self.patch if patch is None else patch, probes=list(self.probes))
        self.runner.resume()
        self.problem = None

    def step(self, back):
        """undo (back) or redo."""
        self.answered()
        source, target = (self.undo_stack, self.redo_stack) if back else (self.redo_stack, self.undo_stack)
        if not source:
            raise CommandError([f"studio: nothing to {'undo' if back else 'redo'}"])
        text, current = source[-1], self.text
        patch = self.accept(text)
        self.gesture = None
        source.pop()
        target.append(current)
        self.undo_bytes += sys.getsizeof(current) if not back else -sys.getsizeof(text)
        self.commit(text, patch, "undo" if back else "redo")
        return {"undo": len(self.undo_stack), "redo": len(self.redo_stack)}

    # -- files ----------------------------------------------------------------------------------
    def diff(self):
        return "".join(difflib.unified_diff(self.saved.splitlines(True), self.text.splitlines(True),
                                            fromfile=self.path, tofile=f"{self.path} (edited)"))

    def save(self, path=None):
        """Write the text atomically (a temporary file beside it, then renamed); the recovery file
        is removed then."""
        self.answered()
        target = self.path if path is None else os.path.join(os.path.dirname(self.path), os.fspath(path))
        if not target.endswith((".yaml", ".yml")):
            raise CommandError([f"studio: save: {path!r}: a patch is saved as a .yaml (or .yml) file"])
        data = self.text.encode("utf-8")
        try:
            mode = os.stat(target).st_mode & 0o7777 if os.path.exists(target) else None
            recovery.write_atomic(target, data, mode)
        except OSError as exc:
            raise CommandError([f"studio: cannot save {target}: {exc.strerror or exc}"]) from None
        recovery.remove(self.path)
        if path is not None:
            self.path = target
            self.patch = self.load_text(self.text)
        self.saved = self.text
        self.unsaved = 0
        recovery.remove(self.path)
        self._emit({**self.describe(), "type": "changed", "cmd": "save"})
        return {"path": target, "bytes": len(data)}
