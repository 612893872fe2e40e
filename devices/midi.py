"""MIDI in (`driver: midi`): a Standard MIDI File rendered headless, or a live port (python-rtmidi).

    devices:
      keys: {driver: midi, port: "Keystation"}     # a substring of the port's name (`hapticgraph devices`)
      song: {driver: midi, file: take.mid}          # beside the patch
    blocks:
      note: {type: midi_note, device: keys, channel: 0, bend_range: 2}
      cut:  {type: midi_cc, device: keys, number: 74, min: 200, max: 8000, curve: exponential}
    voices:                                          # an MPE keyboard (hapticgraph.devices.mpe)
      count: 8
      blocks:
        key: {type: midi_note, device: keys, mpe: lower}

A file's events take effect at the first sample at or after their time, computed exactly from
the ticks and the tempo map (fractions, no rounding), so a note starts at its exact sample in any
block size. Live events are timestamped as they arrive and placed within the audio block
(hapticgraph.devices.events). An entry with neither `port` nor `file` is silent: every block
keeps its starting value (a patch for live play rendered or checked without the keyboard).
"""
import math
import os
import threading
from fractions import Fraction

from .errors import DeviceError
from .events import Hub, Tap
from .mpe import MIDDLE, Zones
from .voices import CHANNEL_MESSAGES, COLUMNS, SLIDE, SLIDE_CC, Allocator, VoiceTap, resolve

DEFAULT_TEMPO = 500000      # µs per beat: 120 beats per minute, the Standard MIDI File default
APIS = {"auto": None, "jack": "UNIX_JACK", "alsa": "LINUX_ALSA"}
POLL = 0.001                # seconds between two reads of an idle live port
JOIN = 1.0                  # seconds a closing port waits for its reading thread


def _error(message):
    return DeviceError(message)


# -- files ---------------------------------------------------------------------------------------

def read_midi_file(path, rate):
    """Every channel message of a Standard MIDI File as (sample, mido.Message), in order: the
    sample is ⌈t·rate⌉ with t exact (ticks through the tempo map, as fractions)."""
    import mido
    mid = mido.MidiFile(path)
    if mid.type == 2:
        raise ValueError("a type 2 (asynchronous) MIDI file has no common time line")
    tpb = Fraction(mid.ticks_per_beat)
    tempo, seconds, out = DEFAULT_TEMPO, Fraction(0), []
    for message in mido.merge_tracks(mid.tracks):
        seconds += Fraction(message.time) * tempo / (tpb * 1_000_000)
        if message.type == "set_tempo":
            tempo = message.tempo
        elif not message.is_meta and hasattr(message, "channel"):
            out.append((math.ceil(seconds * Fraction(rate)), message.copy(time=0)))
    return out


def write_midi_file(path, events, rate):
    """Write (sample, mido.Message) events as a Standard MIDI File in which one tick is one
    sample at `rate` (read back by read_midi_file at the same rate, every event at its sample)."""
    import mido
    r = int(rate)
    if r != rate:
        raise ValueError("a MIDI take needs a whole number of samples per second")
    tpb = r // math.gcd(r, 1_000_000)                       # tpb·1e6/rate µs per beat: a whole number
    while tpb < 96:
        tpb *= 2
    mid = mido.MidiFile(type=0, ticks_per_beat=tpb)
    track = mido.MidiTrack([mido.MetaMessage("set_tempo", tempo=tpb * 1_000_000 // r, time=0)])
    last = 0
    for sample, message in events:
        track.append(message.copy(time=int(sample) - last))
        last = int(sample)
    mid.tracks.append(track)
    mid.save(path)


# -- ports ----------------------------------------------------------------------------------------

def _rtmidi_apis(api="auto"):
    import rtmidi
    os.environ.setdefault("JACK_NO_START_SERVER", "1")   # listing must not start a JACK server
    if APIS[api] is not None:
        return [getattr(rtmidi, "API_" + APIS[api])]
    return [a for a in rtmidi.get_compiled_api() if a != rtmidi.API_RTMIDI_DUMMY]


def list_ports(api="auto"):
    """The MIDI input ports every available backend sees, as (backend name, port name)."""
    import rtmidi
    out = []
    for a in _rtmidi_apis(api):
        try:
            midi_in = rtmidi.MidiIn(a)
        except Exception:  # noqa: BLE001, S112 - a backend without its server (no JACK, no ALSA sequencer)
            continue
        out += [(rtmidi.get_api_name(a), p) for p in midi_in.get_ports()]
        midi_in.delete()
    return out


def port_lines():
    """The `hapticgraph devices` section."""
    try:
        ports = list_ports()
    except ImportError as exc:
        return ["MIDI input ports (python-rtmidi):", f"  unavailable: {exc}"]
    return ["MIDI input ports (python-rtmidi):"] + ([f"  {api}: {p}" for api, p in ports] or ["  none found"])


class PortReader:
    """A live input port through python-rtmidi (the first whose name contains `port`), read by a
    thread of ours that polls the port's queue every POLL seconds.

    Not rtmidi's callback: that runs Python on the MIDI system's own thread (JACK's process
    thread, ALSA's input thread), which must take the GIL for it; and closing the port
    (`close_port`, `delete`) holds the GIL while it waits for that thread to finish its cycle — so
    a message arriving as the port closed deadlocked both (issue 21: `play` never exited under
    JACK). Polled, the MIDI system's thread only fills rtmidi's queue and never waits for Python.
    Each message is stamped with its arrival time: the previous stamp plus rtmidi's delta time
    (the MIDI system's own clock), never later than now, so a burst read at once keeps its
    spacing."""

    def __init__(self, hub, port, api="auto"):
        self.hub, self.port, self.api, self.midi_in = hub, port, api, None
        self.thread, self.stopping = None, threading.Event()

    def open(self):
        import rtmidi
        seen = []
        for a in _rtmidi_apis(self.api):
            try:
                midi_in = rtmidi.MidiIn(a, name="hapticgraph")
            except Exception:  # noqa: BLE001, S112 - this backend has no server here; try the next
                continue
            ports = midi_in.get_ports()
            seen += ports
            match = next((k for k, p in enumerate(ports) if self.port in p), None)
            if match is None:
                midi_in.delete()
                continue
            midi_in.ignore_types(sysex=True, timing=True, active_sense=True)
            midi_in.open_port(match, name="in")
            self.midi_in, self.stopping = midi_in, threading.Event()
            self.thread = threading.Thread(target=self._read, args=(midi_in, self.stopping), daemon=True,
                                           name=f"midi in {self.hub.name}")
            self.thread.start()
            return
        raise _error(f"device {self.hub.name!r}: no MIDI input port matching {self.port!r} "
                     f"(ports: {', '.join(seen) or 'none'}; `hapticgraph devices` lists them)")

    def _read(self, midi_in, stopping):
        import mido
        parser, last = mido.Parser(), None
        while not stopping.is_set():
            got = midi_in.get_message()
            if got is None:
                stopping.wait(POLL)
                continue
            data, delta = got
            now = self.hub.clock()
            last = now if last is None else min(now, last + delta)
            parser.feed(data)
            for message in parser:
                self.hub.post(message, last)

    def close(self):
        """Stop reading (the thread first: nothing touches the port while it closes), then close."""
        midi_in, self.midi_in = self.midi_in, None
        if midi_in is None:
            return
        self.stopping.set()
        if self.thread is not None:
            self.thread.join(JOIN)
        midi_in.close_port()
        midi_in.delete()


class MidiHub(Hub):
    """The driver of a `driver: midi` device entry (see the module's doc)."""

    def __init__(self, name, spec):
        super().__init__(name)
        self.file, self.reader = spec.get("file"), None
        self.allocators = {}      # (channel, voices, mpe) -> the Allocator polyphonic midi_note blocks share
        if spec.get("port") is not None:
            self.reader = PortReader(self, spec["port"], spec.get("api", "auto"))
        elif self.file is None:
            self.timed = []

    def start(self, rate):
        super().start(rate)
        for allocator in self.allocators.values():
            allocator.reset()
        if self.file is not None:
            try:
                self.timed = read_midi_file(self.file, rate)
            except (OSError, ValueError, EOFError) as exc:
                raise _error(f"device {self.name!r}: cannot read the MIDI file {self.file!r}: {exc}") from None
        elif self.reader is not None and self.reader.midi_in is None:
            self.reader.open()

    def stop(self):
        if self.reader is not None:
            self.reader.close()

    def tap(self, inst):
        """The driver of a block that names this device."""
        return TAPS[inst.cls.type_name](self, inst)

    def allocator(self, channel, count, mpe="off"):
        """The voice allocator of a polyphonic group (hapticgraph.devices.voices), shared; `mpe`:
        off, or the zones it plays (hapticgraph.devices.mpe)."""
        key = (channel, count, mpe)
        if key not in self.allocators:
            self.allocators[key] = Allocator(self, channel, count, None if mpe == "off" else Zones(mpe))
        return self.allocators[key]


def _channel_of(inst):
    channel = int(inst.values.get("channel", 0))
    return None if channel == 0 else channel - 1


class NoteTap(Tap):
    """midi_note: last-note priority over the notes held, each a (channel, key) (a release falls
    back to the newest note still held, legato), pitch bend and slide (CC 74) of the sounding
    note's channel, velocity, channel and key pressure. Events at one sample are resolved as the
    voice allocator does (hapticgraph.devices.voices.resolve)."""

    columns = COLUMNS

    def __init__(self, hub, inst):
        self.channel = _channel_of(inst)
        super().__init__(hub, inst)

    def reset(self):
        self.row[:] = (0.0, 69.0, 0.0, 0.0, 0.0, MIDDLE, 0.0)
        self.held = []                 # (channel, key), oldest first
        self.ends = {}                 # (channel, key) -> the sample a note struck and released at one sample ends
        self.bend, self.slide, self.sounding = [0.0] * 16, [MIDDLE] * 16, None

    def fill(self, t0, ext):
        due = {}
        for i, m in self.hub.events(t0, ext.shape[0]):
            if m.type in CHANNEL_MESSAGES and (self.channel is None or m.channel == self.channel):
                due.setdefault(i, []).append(m)
        for end in self.ends.values():
            if end - t0 < ext.shape[0]:
                due.setdefault(max(0, end - t0), [])
        prev, row, n = 0, self.row, ext.shape[0]
        while due:
            i = min(due)
            ext[prev:i] = row
            prev = i
            self.at_sample(due.pop(i), t0 + i)
            for end in self.ends.values():        # a note struck and released here ends at the next sample
                if end - t0 < n:
                    due.setdefault(end - t0, [])
        ext[prev:] = row

    def at_sample(self, messages, at):
        row, held = self.row, self.held
        for note in [note for note, end in self.ends.items() if end <= at]:
            self._drop(note)
        ended, struck, short = resolve(messages, set(held))
        for note in ended:
            self._drop(note)
        for note, m in struck.items():
            if note in held:
                held.remove(note)
            held.append(note)
            row[3], self.sounding = m.velocity / 127.0, m.channel
            self.ends.pop(note, None)
            if note in short:
                self.ends[note] = at + 1
        for m in messages:
            if m.type == "pitchwheel":
                self.bend[m.channel] = m.pitch / 8192.0
            elif m.type == "control_change" and m.control == SLIDE_CC:
                self.slide[m.channel] = m.value / 127.0
            elif m.type == "aftertouch" and m.channel == self.sounding or (
                    m.type == "polytouch" and held and (m.channel, m.note) == held[-1]):
                row[4] = m.value / 127.0
        if held:
            self.sounding = held[-1][0]
            row[0], row[1] = 1.0, held[-1][1]
        else:
            row[0] = 0.0
        if self.sounding is not None:
            row[2], row[SLIDE] = self.bend[self.sounding], self.slide[self.sounding]

    def _drop(self, note):
        self.ends.pop(note, None)
        if note in self.held:
            self.held.remove(note)


class ControlTap(Tap):
    """midi_cc: the value / 127 of one controller number."""

    columns = ("midi_cc",)

    def __init__(self, hub, inst):
        self.channel, self.number = _channel_of(inst), int(inst.values.get("number", 1))
        super().__init__(hub, inst)

    def apply(self, m):
        if m.type == "control_change" and m.control == self.number and (
                self.channel is None or m.channel == self.channel):
            self.row[0] = m.value / 127.0


def note_tap(hub, inst):
    """midi_note's tap: last-note priority, or voice `voice` of a group of `voices` (MPE: `mpe`)."""
    if int(inst.values.get("voice", 0)) > 0:
        return VoiceTap(hub, inst, hub.allocator(_channel_of(inst), int(inst.values.get("voices", 1)),
                                                 inst.values.get("mpe", "off")))
    return NoteTap(hub, inst)


TAPS = {"midi_note": note_tap, "midi_cc": ControlTap}

__all__ = ["ControlTap", "MidiHub", "NoteTap", "PortReader", "list_ports", "port_lines", "read_midi_file",
           "write_midi_file"]
