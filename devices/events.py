"""Timed events to per-sample columns: what the MIDI and OSC drivers share.

A controller device entry (`{driver: midi, ...}`, `{driver: osc, ...}`) opens one Hub: the
connection (a port, a UDP socket) or the file it reads. Each block that names the device
(midi_note, midi_cc, osc_in) gets a Tap of the hub, its own Driver, whose External columns it
writes sample by sample. At each block of samples the hub turns the events due into (sample
index within the block, message) once, and every tap applies those it listens to at their own
sample: the value before the event up to it, the new one from it on.

Timing
    From a file (a Standard MIDI File): each event takes effect at the first sample at or after
    its time, computed exactly (hapticgraph.devices.midi), whatever the block size.
    Live: the reading thread stamps each event with the monotonic clock as it arrives. At a
    block boundary (wall time `now`) the wall-clock interval (now − n/rate, now] stands for the
    samples 1 … n of the block of n samples: an event stamped s lands at sample
    n − ⌊(now − s)·rate⌋ (1 if older); one landing at n, the next block's first sample, is held
    for that block. So the jitter of the block boundaries does not become jitter of the notes;
    the price is a constant latency of one block and one sample (see benchmarks/midi_latency.py
    for measured figures).

Look-ahead
    `peek(t)` gives the events of sample t, the first of the next block, before that block: the
    voice allocator (hapticgraph.devices.voices) dips a restruck voice's gate at the sample
    before its onset. A file knows its future; a live event is known a block ahead of its sample
    at least (never placed at a block's first sample unless held from the block before), so
    the same events give the same columns from a file, a port or a take.
"""
import collections
import math
import time

import numpy as np

from ..graph.engine import Driver


class Hub(Driver):
    """One controller device: its events, block by block. `timed`: a list of (sample, message)
    in order (a file), else live events are `post`ed by a receiving thread. `log`, when a list,
    collects every event delivered as (absolute sample, message): the take of a recording."""

    columns = ()

    def __init__(self, name, timed=None):
        self.name = name
        self.timed = timed
        self.queue = collections.deque()
        self.log = None
        self.rate = 44100.0
        self.lost = None
        self.clock = time.monotonic       # the clock live events are stamped with
        self._block = None
        self._cache = []
        self._at = 0
        self._next = []                   # live: (absolute sample, message) of the next block's first sample

    def start(self, rate):
        self.rate = float(rate)
        self._block, self._cache, self._at, self._next = None, [], 0, []
        self.queue.clear()

    def tap(self, inst):
        """The Driver of block instance `inst` (midi_note, midi_cc, osc_in) naming this device:
        a Tap that reads the events it listens to."""
        raise NotImplementedError

    def post(self, message, stamp=None):
        """A live event (from the receiving thread): thread-safe, never blocks."""
        self.queue.append((self.clock() if stamp is None else stamp, message))

    def events(self, t0, n):
        """The events of samples t0 … t0+n−1 as [(index within the block, message)], in order."""
        if self._block == (t0, n):
            return self._cache
        out = []
        if self.timed is not None:
            timed, end = self.timed, t0 + n
            while self._at < len(timed) and timed[self._at][0] < end:
                sample, message = timed[self._at]
                out.append((max(0, sample - t0), message))
                self._at += 1
        else:
            out = [(max(0, sample - t0), message) for sample, message in self._next]
            self._next = []
            now, rate, queue = self.clock(), self.rate, self.queue
            while queue and queue[0][0] <= now:
                stamp, message = queue.popleft()
                i = min(n, max(1, n - math.floor((now - stamp) * rate)))
                if i < n:
                    out.append((i, message))
                else:
                    self._next.append((t0 + n, message))
        if self.log is not None:
            self.log.extend((t0 + i, m) for i, m in out)
        self._block, self._cache = (t0, n), out
        return out

    def peek(self, t):
        """The messages of absolute sample t, the first of the block after the one `events` gave
        last, in order (see Look-ahead)."""
        if self.timed is None:
            return [message for sample, message in self._next if sample == t]
        out, k, timed = [], self._at, self.timed
        while k < len(timed) and timed[k][0] <= t:
            if timed[k][0] == t:
                out.append(timed[k][1])
            k += 1
        return out


class Tap(Driver):
    """A block's view of a hub: `columns` (its External attributes) held in `row`; subclasses
    say which messages are theirs (`apply` returns False for others) and reset their state."""

    columns = ()

    def __init__(self, hub, inst):
        self.hub, self.name = hub, inst.name
        self.row = np.zeros(len(self.columns))
        self.reset()

    def reset(self):
        self.row[:] = 0.0

    def start(self, rate):
        self.reset()

    def apply(self, message):
        raise NotImplementedError

    def fill(self, t0, ext):
        prev, row = 0, self.row
        for i, message in self.hub.events(t0, ext.shape[0]):
            if i > prev:
                ext[prev:i] = row
                prev = i
            self.apply(message)
        ext[prev:] = row


__all__ = ["Hub", "Tap"]
