"""The session thread: the patch running in real time, paced by the sound card (`--audio card`,
through devices.audio.Player as `play`) or by the clock (`--audio none|browser`: blocks at the
real-time rate). Both call `Live.process` block by block, which applies what the studio queued
(live parameters, a swapped-in patch) at the block boundary. A safety stop (NaN, runaway, a
device lost) silences the sound until `resume` (the next edit or a restart)."""
import threading
import time

from ..devices import audio
from ..session import SafetyStop

BEHIND = 0.25          # seconds behind the clock after which the clock runner skips ahead


class ClockRunner:
    """Runs the Live session block by block at the real-time rate on its own thread."""

    def __init__(self, live, tap, on_problem):
        self.live, self.tap, self.on_problem = live, tap, on_problem
        self.problem = None
        self.stopping = threading.Event()
        self.late = 0               # times the clock runner fell behind and skipped ahead
        self.busy = self.elapsed = 0.0
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-studio", daemon=True)

    def start(self):
        self.live.start()
        self.thread.start()
        return self

    def stop(self):
        self.stopping.set()
        if self.thread.is_alive():
            self.thread.join(5.0)

    @property
    def xruns(self):
        return self.late

    @property
    def load(self):
        return self.busy / self.elapsed if self.elapsed else 0.0

    def resume(self):
        self.problem = None

    def _loop(self):
        bs = self.live.blocksize
        period = bs / self.live.rate
        due = time.perf_counter()
        while not self.stopping.is_set():
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
        try:
            rec = self.live.process(n)
            self.tap.block(self.live, rec)
        except SafetyStop as exc:
            self.problem = str(exc)
            self.on_problem(self.problem)
        except Exception as exc:  # noqa: BLE001 - the sound stops, the studio stays up and says why
            self.problem = f"{type(exc).__name__}: {exc}"
            self.on_problem(self.problem)


class CardRunner:
    """Plays through the sound card with devices.audio.Player (as `play`); the tap takes frames
    after each block (the Player's probe_out). After a safety stop the stream ends; `resume`
    opens it again."""

    def __init__(self, live, tap, on_problem, device=None, blocksize=256):
        self.live, self.tap, self.on_problem = live, tap, on_problem
        self.device, self.blocksize = device, blocksize
        self.problem = None
        self.player = None
        self.again = threading.Event()
        self.stopping = threading.Event()
        self.flags = 0
        tap.current = lambda: self.live
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-studio-card", daemon=True)

    def _open(self):
        return audio.Player(self.live, device=self.device, blocksize=self.blocksize, probe_out=self.tap)

    def start(self):
        self.player = self._open()
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
        self.again.set()
        if self.player is not None:
            self.player.request_stop()
        if self.thread.is_alive():
            self.thread.join(5.0)

    def resume(self):
        if self.problem is not None:
            self.again.set()

    def _loop(self):
        while not self.stopping.is_set():
            player = self.player
            if player is None:
                self.again.wait()
                self.again.clear()
                continue
            try:
                report = player.run()
            except Exception as exc:  # noqa: BLE001 - reported to the page, the studio stays up
                report = None
                self.problem = f"{type(exc).__name__}: {exc}"
                self.on_problem(self.problem)
            self.flags += sum(v for k, v in player.flag_counts.items() if k != "priming_output")
            self.player = None
            if self.stopping.is_set():
                break
            if report is not None and report.problem:
                self.problem = report.problem
                self.on_problem(self.problem)
            self.again.wait()
            self.again.clear()
            if self.stopping.is_set():
                break
            try:
                self.player = self._open()
                self.problem = None
            except audio.AudioError as exc:
                self.problem = str(exc)
                self.on_problem(self.problem)
                self.player = None
