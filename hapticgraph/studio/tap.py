"""What the running sound shows the page, taken after each block on the audio thread: the
latest cell frame of every body (at most `fps` a second; a newer frame replaces an unsent one),
the audio (with --audio browser) and the probed signals, packed as docs/studio.md's binary
frames. Pages read them from their own tasks; nothing here waits for a page."""
import collections
import struct
import threading
import time

import numpy as np

from .adapter import cells_of
from .describe import bodies

CELLS, AUDIO, PROBE = 1, 2, 3
AUDIO_CHUNK = 1024                    # samples per audio frame
AUDIO_KEEP = 0.5                      # seconds of audio queued for a page, then the oldest go
PROBE_PER_SECOND = 30                 # probe frames a second
PROBE_KEEP = 1.0                      # seconds of probe data queued


def cell_frame(body_id, counter, t, shape, values):
    """A kind-1 frame: header (kind, ndim, id, counter, sample index, shape) + float32 cells."""
    head = struct.pack(f"<BBHIQ{len(shape)}I", CELLS, len(shape), body_id, counter & 0xFFFFFFFF, t, *shape)
    return head + values.tobytes()


def stream_frame(kind, channels_or_zero, ident, counter, t0, rate, data):
    """A kind-2 (audio, interleaved) or kind-3 (probe) frame."""
    frames = data.shape[0]
    head = struct.pack("<BBHIQII", kind, channels_or_zero, ident, counter & 0xFFFFFFFF, t0, int(rate), frames)
    return head + np.ascontiguousarray(data, dtype="<f4").tobytes()


class _Chunker:
    """Fills a float32 buffer block by block; a full one becomes a frame."""

    def __init__(self, kind, ident, columns, chunk, rate):
        self.kind, self.ident, self.columns, self.rate = kind, ident, columns, rate
        self.buf = np.zeros((chunk, len(columns)), dtype=np.float32)
        self.fill, self.t0, self.counter = 0, 0, 0

    def push(self, rec, t0, out):
        n, pos = rec.shape[0], 0
        while pos < n:
            if self.fill == 0:
                self.t0 = t0 + pos
            k = min(n - pos, self.buf.shape[0] - self.fill)
            self.buf[self.fill:self.fill + k] = rec[pos:pos + k, self.columns]
            self.fill += k
            pos += k
            if self.fill == self.buf.shape[0]:
                data = self.buf if self.kind == AUDIO else self.buf[:, 0]
                out(stream_frame(self.kind, len(self.columns) if self.kind == AUDIO else 0, self.ident,
                                 self.counter, self.t0, self.rate, data))
                self.counter += 1
                self.fill = 0


class Tap:
    """Takes frames from the running session. `probes` maps a probed signal to its id; the
    session's records name its columns. Also the `probe_out` of devices.audio.Player."""

    def __init__(self, fps=60, audio=False):
        self.fps = float(fps)
        self.audio = bool(audio)
        self.counter = 0
        self.frame = None             # (counter, [bytes per body]): the latest only
        self.last = 0.0
        self.lock = threading.Lock()
        self.queue = collections.deque()   # (seq, bytes): audio and probe frames, bounded
        self.seq = 0
        self.limit = 64
        self.probes = {}
        self.bound = None             # the Program the views below are of (a swap makes another)
        self.current = None           # a callable giving the Live session (the Player's probe_out)

    # the Player's probe_out interface
    def start(self, rate, channels, labels, path):
        pass

    def write(self, rec):
        self.block(self.current(), rec)

    def close(self):
        pass

    def set_probes(self, probes):
        """{signal: id}; takes effect with the next session (its records include them)."""
        self.probes = dict(probes)
        self.bound = None

    def _bind(self, live):
        prog = live.prog
        labels = [label for label, _ in prog.records]
        rate = live.rate
        self.bodies = []
        for i, (name, shape) in enumerate(bodies(prog.patch)):
            flat, where = cells_of(live.session, name)
            self.bodies.append((i, shape, flat, where, np.full(int(np.prod(shape)), np.nan, dtype="<f4")))
        self.streams = []
        if self.audio and prog.channels:
            self.streams.append(_Chunker(AUDIO, 0, list(range(prog.channels)), AUDIO_CHUNK, rate))
        chunk = max(1, int(rate / PROBE_PER_SECOND))
        for signal, ident in self.probes.items():
            if signal in labels:
                self.streams.append(_Chunker(PROBE, ident, [labels.index(signal)], chunk, rate))
        per_second = (rate / AUDIO_CHUNK if self.audio else 0) + PROBE_PER_SECOND * len(self.probes)
        self.limit = max(8, int(per_second * max(AUDIO_KEEP, PROBE_KEEP if self.probes else 0)))
        self.bound = prog

    def block(self, live, rec):
        """After each block of `live` (adapter.Live): `rec` the block (audio channels first)."""
        if live.prog is not self.bound:
            self._bind(live)
        n = rec.shape[0]
        t0 = live.t - n
        for s in self.streams:
            s.push(rec, t0, self._queue)
        now = time.monotonic()
        if self.fps > 0 and now - self.last >= 1.0 / self.fps:
            self.last = now
            self.snapshot(live.t)

    def snapshot(self, t):
        """The latest cell frame of every body (replacing any unsent one)."""
        self.counter += 1
        frames = []
        for i, shape, pos, where, buf in self.bodies:
            if where is None:
                np.copyto(buf, pos.reshape(-1), casting="same_kind")
            else:                              # cut cells are not in the array: NaN in the frame
                buf[where] = pos.reshape(-1)
            frames.append(cell_frame(i, self.counter, t, shape, buf))
        self.frame = (self.counter, frames)

    def _queue(self, data):
        with self.lock:
            self.seq += 1
            self.queue.append((self.seq, data))
            while len(self.queue) > self.limit:
                self.queue.popleft()

    def streaming(self):
        """True while audio or probe frames are being made."""
        return bool(self.audio or self.probes)

    def since(self, seq):
        """[(seq, bytes)] of the queued audio and probe frames newer than `seq`."""
        with self.lock:
            if not self.queue or self.queue[-1][0] <= seq:
                return []
            return [item for item in self.queue if item[0] > seq]
