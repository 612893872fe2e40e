"""The session thread: the patch running in real time, paced by the sound card (`--audio card`,
through devices.audio.Player as `play`) or by the clock (`--audio none|browser`: blocks at the
real-time rate). Edits land at block boundaries: live parameters queued on the session, an
edited patch swapped in with its state carried over. A safety stop (NaN, runaway, a device lost)
silences the sound until the next swap or restart."""
import threading
import time

import numpy as np

from ..devices import audio
from ..graph.engine import SafetyStop

SWAP_TIMEOUT = 5.0
BEHIND = 0.25          # seconds behind the clock after which the clock runner skips ahead


class ClockRunner:
    """Runs `session` block by block at the real-time rate on its own thread."""

    def __init__(self, session, tap, on_problem):
        self.session, self.tap, self.on_problem = session, tap, on_problem
        self.problem = None
        self.pending = None
        self.swapped = threading.Event()
        self.stopping = threading.Event()
        self.late = 0               # times the clock runner fell behind and skipped ahead
        self.busy = self.elapsed = 0.0
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-studio", daemon=True)

    def start(self):
        self.session.start()
        self.thread.start()
        return self

    def stop(self):
        self.stopping.set()
        if self.thread.is_alive() and self.thread is not threading.current_thread():
            self.thread.join(5.0)
        self.session.stop()

    @property
    def xruns(self):
        return self.late

    @property
    def load(self):
        return self.busy / self.elapsed if self.elapsed else 0.0

    def swap(self, session, pairs, restart=False):
        """Swap `session` in at the next block boundary (state from `pairs`, (dst, src); time
        kept unless `restart`); True once it plays."""
        self.swapped.clear()
        self.pending = (session, pairs, restart)
        if self.swapped.wait(SWAP_TIMEOUT):
            return True
        self.pending = None
        return False

    def _swap(self):
        session, pairs, restart = self.pending
        old = self.session
        for dst, src in pairs:
            np.copyto(dst, src)
        session.t = 0 if restart else old.t
        session.started = True
        self.session = session
        self.problem = None
        self.pending = None
        self.swapped.set()

    def _loop(self):
        bs = self.session.blocksize
        period = bs / self.session.rate
        due = time.perf_counter()
        while not self.stopping.is_set():
            if self.pending is not None:
                self._swap()
            if self.problem is None:
                began = time.perf_counter()
                self._block(bs)
                self.busy += time.perf_counter() - began
            due += period
            wait = due - time.perf_counter()
            if wait > 0:
                self.stopping.wait(wait)
            elif wait < -BEHIND:
                self.late += 1
                due = time.perf_counter()
            self.elapsed += period

    def _block(self, n):
        session = self.session
        try:
            rec = session.process(n)
            self.tap.block(session, rec)
        except SafetyStop as exc:
            self.problem = str(exc)
            self.on_problem(self.problem)
        except Exception as exc:  # noqa: BLE001 - the sound stops, the studio stays up and says why
            self.problem = f"{type(exc).__name__}: {exc}"
            self.on_problem(self.problem)


class CardRunner:
    """Plays through the sound card with devices.audio.Player (as `play`); the tap takes frames
    after each block (the Player's probe_out)."""

    def __init__(self, session, tap, on_problem, device=None, blocksize=256):
        self.session, self.tap, self.on_problem = session, tap, on_problem
        self.device, self.blocksize = device, blocksize
        self.problem = None
        self.player = None
        self.resume = threading.Event()
        self.stopping = threading.Event()
        self.next = None
        self.flags = 0
        tap.current = lambda: self.player.bound.session
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-studio-card", daemon=True)

    def start(self):
        self.player = audio.Player(self.session, device=self.device, blocksize=self.blocksize, probe_out=self.tap)
        self.thread.start()
        return self

    @property
    def xruns(self):
        p = self.player
        return self.flags + (sum(v for k, v in p.flag_counts.items() if k != "priming_output") if p else 0)

    @property
    def load(self):
        p = self.player
        return p.busy / p.period_total if p is not None and p.period_total else 0.0

    def stop(self):
        self.stopping.set()
        self.resume.set()
        if self.player is not None:
            self.player.request_stop()
        if self.thread.is_alive():
            self.thread.join(5.0)

    def _loop(self):
        while not self.stopping.is_set():
            player = self.player
            report = None
            try:
                report = player.run()
            except Exception as exc:  # noqa: BLE001 - reported to the page, the studio stays up
                self.problem = f"{type(exc).__name__}: {exc}"
                self.on_problem(self.problem)
            self.flags += sum(v for k, v in player.flag_counts.items() if k != "priming_output")
            if self.stopping.is_set():
                break
            if report is not None and report.problem:
                self.problem = report.problem
                self.on_problem(self.problem)
            self.resume.wait()           # a swap or a restart brings the next session
            self.resume.clear()
            if self.stopping.is_set() or self.next is None:
                break
            self.session, self.next = self.next, None
            self.player = audio.Player(self.session, device=self.device, blocksize=self.blocksize,
                                       probe_out=self.tap)
            self.problem = None

    def swap(self, session, pairs, restart=False):
        """As ClockRunner.swap; a restart (or a swap after a safety stop) opens the stream again."""
        player = self.player
        if not restart and self.problem is None and not player.done.is_set():
            bound = player.bind(session)
            bound.carry = pairs
            if player.offer(bound, SWAP_TIMEOUT):
                self.session = session
                return True
            if not player.done.is_set():
                return False
        if not restart:                  # the stream has stopped: nothing runs the old session
            for dst, src in pairs:
                np.copyto(dst, src)
            session.t = player.bound.session.t
        session.started = True
        self.next = session
        if not player.done.is_set():
            player.request_stop()
        self.resume.set()
        return True
