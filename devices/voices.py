"""Voice allocation: polyphonic `midi_note` blocks (`voice: k` of `voices: N`, numbered by a
`voices:` template) share one Allocator per device, channel and group size, which turns the
device's events into N voices' columns once per block of samples, each event at its own sample.

A note-on takes
1. the voice already holding that key (a repeated key restrikes its own voice), else
2. a free voice (never used, or released): the one released longest ago, so a released voice
   keeps ringing as long as it can, else
3. the voice holding the oldest note (it is stolen).
A note-off drops its voice's gate and leaves the rest as it was (freq, velocity): the voice
rings on, released, until a note-on reuses it. A free voice's gate rises at the note-on's
sample; a stolen (or restruck) voice's gate falls at the note-on's sample and rises at the next
one, so gate-triggered blocks (pluck, envelope) start again; its freq and velocity change at
the note-on's sample. Pitch bend and channel pressure reach every voice; key pressure the voice
holding the key; all-notes-off (CC 123) and all-sound-off (CC 120) release every voice.
"""
import numpy as np

from .events import Tap

GATE, NOTE, BEND, VELOCITY, PRESSURE = range(5)
ALL_OFF = (120, 123)


class Allocator:
    """The notes of one channel (None: every channel) shared among `count` voices."""

    def __init__(self, hub, channel, count):
        self.hub, self.channel, self.count = hub, channel, count
        self.reset()

    def reset(self):
        n = self.count
        self.rows = np.zeros((n, 5))
        self.rows[:, NOTE] = 69.0
        self.key = [None] * n          # the key each voice sounds, held or ringing
        self.held = [False] * n
        self.since = list(range(-n, 0))  # event count at the voice's note-on (held) or release (free)
        self.clock = 0
        self.rearm = {}                # voice -> the absolute sample its gate rises again after a steal
        self._block, self.cols = None, np.zeros((0, n, 5))

    def voice_for(self, note):
        """The voice a note-on of `note` takes (see the module's doc)."""
        for v in range(self.count):
            if self.held[v] and self.key[v] == note:
                return v
        free = [v for v in range(self.count) if not self.held[v]]
        return min(free or range(self.count), key=self.since.__getitem__)

    def apply(self, m, at):
        """One message at absolute sample `at`."""
        rows, kind = self.rows, m.type
        if kind == "note_on" and m.velocity > 0:
            v = self.voice_for(m.note)
            rows[v, NOTE], rows[v, VELOCITY], rows[v, PRESSURE] = m.note, m.velocity / 127.0, 0.0
            if rows[v, GATE] > 0.0 or v in self.rearm:
                rows[v, GATE] = 0.0
                self.rearm[v] = at + 1
            else:
                rows[v, GATE] = 1.0
            self.key[v], self.held[v], self.since[v] = m.note, True, self.clock
        elif kind in ("note_off", "note_on"):
            for v in range(self.count):
                if self.held[v] and self.key[v] == m.note:
                    self._release(v)
        elif kind == "pitchwheel":
            rows[:, BEND] = m.pitch / 8192.0
        elif kind == "aftertouch":
            rows[:, PRESSURE] = m.value / 127.0
        elif kind == "polytouch":
            for v in range(self.count):
                if self.held[v] and self.key[v] == m.note:
                    rows[v, PRESSURE] = m.value / 127.0
        elif kind == "control_change" and m.control in ALL_OFF:
            for v in range(self.count):
                if self.held[v]:
                    self._release(v)
        self.clock += 1

    def _release(self, v):
        self.held[v], self.since[v] = False, self.clock
        self.rows[v, GATE] = 0.0
        self.rearm.pop(v, None)

    def _mine(self, m):
        return hasattr(m, "channel") and (self.channel is None or m.channel == self.channel)

    def block(self, t0, n):
        """Every voice's columns for samples t0 … t0+n−1: an n × count × 5 array (computed once
        per block, whichever voice asks first)."""
        if self._block == (t0, n):
            return self.cols
        if self.cols.shape[0] != n:
            self.cols = np.zeros((n, self.count, 5))
        events = [(i, m) for i, m in self.hub.events(t0, n) if self._mine(m)]
        cursor, e, rows = 0, 0, self.rows
        while cursor < n:
            for v in [v for v, at in self.rearm.items() if at - t0 <= cursor]:
                rows[v, GATE] = 1.0
                del self.rearm[v]
            while e < len(events) and events[e][0] <= cursor:
                self.apply(events[e][1], t0 + cursor)
                e += 1
            later = [at - t0 for at in self.rearm.values()] + ([events[e][0]] if e < len(events) else [])
            nxt = min([n] + later)
            self.cols[cursor:nxt] = rows
            cursor = nxt
        self._block = (t0, n)
        return self.cols


class VoiceTap(Tap):
    """midi_note with `voice: k` (k ≥ 1): voice k's columns from its group's Allocator."""

    columns = ("midi_gate", "midi_note", "midi_bend", "midi_velocity", "midi_pressure")

    def __init__(self, hub, inst, allocator):
        self.allocator, self.voice = allocator, int(inst.values["voice"]) - 1
        super().__init__(hub, inst)

    def fill(self, t0, ext):
        ext[:] = self.allocator.block(t0, ext.shape[0])[:, self.voice, :]


__all__ = ["Allocator", "VoiceTap"]
