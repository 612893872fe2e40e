"""Voice allocation: polyphonic `midi_note` blocks (`voice: k` of `voices: N`, numbered by a
`voices:` template) share one Allocator per device, channel and group size, which turns the
device's events into N voices' columns once per block of samples, each event at its own sample.

A note is owned by its channel and key: a voice sounds one note of one channel, and a note-off
(or a note-on of velocity 0) ends that note only. Two channels striking one key take two voices.
A note-on takes
1. the voice holding the same note (channel and key) — a repeated note restrikes its own voice, else
2. a free voice (never used, or released): the one released longest ago, so a released voice
   keeps ringing as long as it can, else
3. the voice holding the oldest note (it is stolen).
So with more voices than notes sounding nothing is stolen; with fewer, the oldest note is.
A note-off drops its voice's gate and leaves the rest as it was (freq, velocity): the voice
rings on, released, until a note-on reuses it.

Every change happens at its event's sample. A voice whose gate is up when it takes a new note
(restruck, stolen, or released and reused at that very sample) shows the new onset with a
one-sample dip *before* it: its gate is 0 at the sample before the note-on and 1 from the
note-on's sample, so gate-triggered blocks (pluck, envelope) start again exactly on time (the
allocator looks one sample ahead; hapticgraph.devices.events). Events at one sample are resolved
whatever their order in the file: a note-off there ends the note of its channel and key that
began earlier, else one struck at that sample (which then sounds for that one sample); so a
note-off and a note-on of one key at one sample leave the new note sounding.
Pitch bend, channel pressure and CC 74 (slide) reach every voice of their channel; key pressure
the voice holding the key; all-notes-off (CC 123) and all-sound-off (CC 120) release every note
of their channel.

MPE (`mpe: lower|upper|auto`: an Allocator given Zones, hapticgraph.devices.mpe): the notes of
the played zones' channels only. A note's detune is its own bend (its member channel's, while the
note is held) plus its zone master's; its pressure and slide are set by its member channel while
held and by the master channel always; a note-on takes its channel's values, and the channel's
last note ending resets them. At one sample: the RPN messages first (an MPE Configuration Message
that moves channels between zones ends their notes), then the notes, then the rest. All-notes-off
on a master channel ends every note of its zone.
"""
import numpy as np

from .events import Tap
from .mpe import MIDDLE, RPN_CONTROLS

GATE, NOTE, BEND, VELOCITY, PRESSURE, SLIDE, DETUNE = range(7)
COLUMNS = ("midi_gate", "midi_note", "midi_bend", "midi_velocity", "midi_pressure", "midi_slide", "midi_detune")
SLIDE_CC = 74
ALL_OFF = (120, 123)
CHANNEL_MESSAGES = frozenset(("note_on", "note_off", "polytouch", "control_change", "program_change",
                              "aftertouch", "pitchwheel"))


def is_note_on(m):
    return m.type == "note_on" and m.velocity > 0


def is_note_off(m):
    return m.type == "note_off" or (m.type == "note_on" and m.velocity == 0)


def resolve(messages, held):
    """The note events of one sample, whatever their order: (notes ended that began before it,
    {note: its note-on message} of the notes struck, notes struck that also end there), each
    note a (channel, key); `held`: the notes sounding before the sample."""
    ended, struck, short = [], {}, set()
    for m in messages:
        if is_note_on(m):
            note = (m.channel, m.note)
            struck[note] = m
            short.discard(note)
        elif is_note_off(m):
            _end(m.channel, (m.note,), held, ended, struck, short)
        elif m.type == "control_change" and m.control in ALL_OFF:
            _end(m.channel, range(128), held, ended, struck, short)
    return ended, struck, short


def _end(channel, keys, held, ended, struck, short):
    for key in keys:
        note = (channel, key)
        if note in held and note not in ended:
            ended.append(note)
        elif note in struck:
            short.add(note)


class Allocator:
    """The notes of one channel (None: every channel) shared among `count` voices; with `zones`
    (hapticgraph.devices.mpe.Zones), the notes of an MPE zone."""

    def __init__(self, hub, channel, count, zones=None):
        self.hub, self.channel, self.count, self.zones = hub, channel, count, zones
        self.reset()

    def reset(self):
        n = self.count
        self.rows = np.zeros((n, len(COLUMNS)))
        self.rows[:, NOTE] = 69.0
        self.rows[:, SLIDE] = MIDDLE
        if self.zones is not None:
            self.zones.reset()
        self.zone_of = [None] * n        # MPE: the zone of each voice's note
        self.own = [0.0] * n             # MPE: each voice's own bend [semitones]
        self.owner = [None] * n          # the (channel, key) each voice sounds, held or ringing
        self.held = [False] * n
        self.since = list(range(-n, 0))  # event count at the voice's note-on (held) or release (free)
        self.clock = 0
        self.ends = {}                   # voice -> the absolute sample its one-sample note ends
        self.bend, self.pressure, self.slide = [0.0] * 16, [0.0] * 16, [MIDDLE] * 16
        self.done = -1                   # the last absolute sample whose events are applied
        self._block, self.cols = None, np.zeros((n, 0, len(COLUMNS)))

    def voice_for(self, note):
        """The voice a note-on of `note` (channel, key) takes (see the module's doc)."""
        for v in range(self.count):
            if self.held[v] and self.owner[v] == note:
                return v
        free = [v for v in range(self.count) if not self.held[v]]
        return min(free or range(self.count), key=self.since.__getitem__)

    def at_sample(self, messages, at):
        """Apply every message of absolute sample `at` (and the ends due there); the voices whose
        gate must dip at the sample before (their gate was up and they take a new note)."""
        rows = self.rows
        before = rows[:, GATE].copy()
        for v in [v for v, end in self.ends.items() if end <= at]:
            self._release(v)
        if self.zones is not None:
            messages = self._zone_messages(messages)
        held = {self.owner[v] for v in range(self.count) if self.held[v]}
        ended, struck, short = resolve(messages, held)
        for note in ended:
            self._release(next(v for v in range(self.count) if self.held[v] and self.owner[v] == note))
        dips = []
        for note, m in struck.items():
            v = self.voice_for(note)
            self._strike(v, m)
            self.owner[v], self.held[v], self.since[v] = note, True, self.clock
            self.ends.pop(v, None)
            self.clock += 1
            if before[v] > 0.0:
                dips.append(v)
            if note in short:
                self.ends[v] = at + 1
        for m in messages:
            self._control(m)
        return dips

    def _strike(self, v, m):
        """Voice v takes note-on `m`: its channel's values at this sample."""
        c, zones = m.channel, self.zones
        if zones is None:
            self.rows[v] = (1.0, m.note, self.bend[c], m.velocity / 127.0, 0.0, self.slide[c], 0.0)
            return
        z = zones.zone_of(c)
        self.zone_of[v], self.own[v] = z, zones.own(c)
        self.rows[v] = (1.0, m.note, 0.0, m.velocity / 127.0, zones.pressure[c], zones.slide[c],
                        self.own[v] + zones.common(z))

    def _control(self, m):
        """Pitch bend, channel and key pressure, slide (CC 74)."""
        if self.zones is not None:
            self._expression(m)
            return
        rows, kind = self.rows, m.type
        if kind == "pitchwheel":
            self.bend[m.channel] = m.pitch / 8192.0
            rows[self._voices_of(m.channel), BEND] = self.bend[m.channel]
        elif kind == "aftertouch":
            self.pressure[m.channel] = m.value / 127.0
            rows[self._voices_of(m.channel), PRESSURE] = self.pressure[m.channel]
        elif kind == "control_change" and m.control == SLIDE_CC:
            self.slide[m.channel] = m.value / 127.0
            rows[self._voices_of(m.channel), SLIDE] = self.slide[m.channel]
        elif kind == "polytouch":
            self._key_pressure(m)

    def _key_pressure(self, m):
        for v in range(self.count):
            if self.held[v] and self.owner[v] == (m.channel, m.note):
                self.rows[v, PRESSURE] = m.value / 127.0

    def _voices_of(self, channel):
        return [v for v in range(self.count) if self.owner[v] is not None and self.owner[v][0] == channel]

    # -- MPE -------------------------------------------------------------------------------------
    def _zone_messages(self, messages):
        """Apply the sample's RPN messages (in order), then keep the rest that concern the zones
        as those left them (a note on a channel a Configuration Message at that sample moved out
        is not played), all-notes-off on a master channel spread over its zone's channels."""
        zones, out = self.zones, []
        rpn = [m.type == "control_change" and m.control in RPN_CONTROLS for m in messages]
        for m in (m for m, is_rpn in zip(messages, rpn) if is_rpn):
            moved, ranges = zones.configure(m)
            for v in range(self.count):
                if self.held[v] and self.owner[v][0] in moved:
                    self._release(v)
            if ranges:
                self._retune()
        for m in (m for m, is_rpn in zip(messages, rpn) if not is_rpn and zones.zone_of(m.channel) is not None):
            if m.type == "control_change" and m.control in ALL_OFF and zones.is_master(m.channel):
                out += [m.copy(channel=c) for c in zones.channels(zones.zone_of(m.channel))]
            else:
                out.append(m)
        return out

    def _expression(self, m):
        """MPE: bend, channel pressure and slide of a member channel reach its held notes, of a
        master channel every note of its zone; key pressure the note it names."""
        zones, rows, c, kind = self.zones, self.rows, m.channel, m.type
        column = {"pitchwheel": DETUNE, "aftertouch": PRESSURE}.get(kind)
        if kind == "control_change" and m.control == SLIDE_CC:
            column = SLIDE
        if column is None:
            if kind == "polytouch":
                self._key_pressure(m)
            return
        if kind == "pitchwheel":
            zones.bend[c] = m.pitch / 8192.0
        elif kind == "aftertouch":
            zones.pressure[c] = m.value / 127.0
        else:
            zones.slide[c] = m.value / 127.0
        master, z = zones.is_master(c), zones.zone_of(c)
        if master:
            voices = [v for v in range(self.count) if self.owner[v] is not None and self.zone_of[v] == z]
        else:
            voices = [v for v in range(self.count) if self.held[v] and self.owner[v][0] == c]
        if column == DETUNE:
            for v in voices:
                if not master:
                    self.own[v] = zones.own(c)
                rows[v, DETUNE] = self.own[v] + zones.common(self.zone_of[v])
        else:
            rows[voices, column] = zones.pressure[c] if column == PRESSURE else zones.slide[c]

    def _retune(self):
        """A bend range changed: every held note's own bend, and every note's master part, again."""
        zones = self.zones
        for v in range(self.count):
            if self.owner[v] is None or self.zone_of[v] is None:
                continue
            if self.held[v] and zones.zone_of(self.owner[v][0]) == self.zone_of[v]:
                self.own[v] = zones.own(self.owner[v][0])
            self.rows[v, DETUNE] = self.own[v] + zones.common(self.zone_of[v])

    def _release(self, v):
        self.held[v], self.since[v] = False, self.clock
        self.clock += 1
        self.rows[v, GATE] = 0.0
        self.ends.pop(v, None)
        channel = self.owner[v][0]
        if self.zones is not None and not self.zones.is_master(channel) and not any(
                self.held[u] and self.owner[u][0] == channel for u in range(self.count)):
            self.zones.clear(channel)

    def _mine(self, m):
        return m.type in CHANNEL_MESSAGES and (self.channel is None or m.channel == self.channel)

    def _due(self, t0, n):
        """{index within the block (0 … n, n: the next block's first sample, looked ahead): the
        messages there} of the samples not applied yet, ends included."""
        due = {}
        for i, m in self.hub.events(t0, n):
            if t0 + i > self.done and self._mine(m):
                due.setdefault(i, []).append(m)
        for m in self.hub.peek(t0 + n):
            if self._mine(m):
                due.setdefault(n, []).append(m)
        for end in self.ends.values():
            if t0 + n >= end > self.done:
                due.setdefault(max(0, end - t0), [])
        return due

    def block(self, t0, n):
        """Every voice's columns for samples t0 … t0+n−1: a count × n × len(COLUMNS) array, each
        voice's rows contiguous (computed once per block, whichever voice asks first)."""
        if self._block == (t0, n):
            return self.cols
        if self.cols.shape[1] != n:
            self.cols = np.zeros((self.count, n, len(COLUMNS)))
        cols, cursor, due = self.cols, 0, self._due(t0, n)
        while due:
            i = min(due)
            cols[:, cursor:i] = self.rows[:, None, :]
            cursor = i
            for v in self.at_sample(due.pop(i), t0 + i):
                if i > 0:
                    cols[v, i - 1, GATE] = 0.0
            self.done = t0 + i
            for end in self.ends.values():        # a note struck and released here ends at the next sample
                if end - t0 <= n:
                    due.setdefault(end - t0, [])
        cols[:, cursor:n] = self.rows[:, None, :]
        self._block = (t0, n)
        return cols


class VoiceTap(Tap):
    """midi_note with `voice: k` (k ≥ 1): voice k's columns from its group's Allocator."""

    columns = COLUMNS

    def __init__(self, hub, inst, allocator):
        self.allocator, self.voice = allocator, int(inst.values["voice"]) - 1
        super().__init__(hub, inst)

    def fill(self, t0, ext):
        ext[:] = self.allocator.block(t0, ext.shape[0])[self.voice]


__all__ = ["CHANNEL_MESSAGES", "COLUMNS", "DETUNE", "SLIDE", "SLIDE_CC", "Allocator", "VoiceTap", "is_note_off",
           "is_note_on", "resolve"]
