"""Controllers musicians own: MIDI notes and controllers, OSC values. Each block is fed by its
device's driver (hapticgraph.devices.midi / .osc) through External columns written per sample, so
an event takes effect at its own sample, inside an audio block."""
import math

from .vocabulary import Block, External, Out, Param, State

DEVICE_DOC = "the name of a controller entry under devices: (driver midi or osc)"
A4 = 69.0          # MIDI note number of 440 Hz
MAX_VOICES = 128   # a polyphonic group's largest size: one voice per MIDI key
MPE_MODES = ("off", "lower", "upper", "auto")


class MidiNote(Block, name="midi_note"):
    """freq = 440·2^((note − 69 + bend·bend_range + detune)/12); gate, velocity, pressure, slide as received (last-note priority, or voice `voice` of `voices` allocated; `mpe`: per-note bend, pressure and slide)."""

    g = Out(name="gate", doc="1 while a key is held, else 0")
    f = Out(name="freq", doc="the sounding note's frequency, pitch bend applied [Hz] (440 before any note)")
    vel = Out(name="velocity", doc="the sounding note's on-velocity, 0–1")
    press = Out(name="pressure", doc="channel or key pressure (aftertouch), 0–1")
    sl = Out(name="slide", doc="CC 74 (MPE: the note's own, its slide) / 127, 0–1; 64/127 until one is received")
    device = Param("", refers="controller", doc=DEVICE_DOC)
    channel = Param(0, minimum=0, maximum=16, doc="MIDI channel 1–16; 0: omni (every channel)")
    bend_range = Param(2.0, unit="semitones", minimum=0.0, maximum=48.0,
                       doc="pitch bend at full deflection (not used with mpe: the zone's ranges are)")
    voice = Param(0, minimum=0, maximum=MAX_VOICES, refers="voice",
                  doc="0: the keyboard's newest key; k ≥ 1: voice k of a polyphonic group (set by a voices: template)")
    voices = Param(1, minimum=1, maximum=MAX_VOICES, refers="voices",
                   doc="the group's number of voices: free voice first, else the oldest note is stolen")
    mpe = Param("off", choices=MPE_MODES,
                doc="MPE keyboards: the lower zone (master channel 1), the upper (master 16), or auto: "
                    "the zones the MPE Configuration Messages set up")
    notes = """Notes and voices (hapticgraph.devices.voices): a note belongs to its channel and key; a
note-off (or a note-on of velocity 0, or all-notes-off of its channel) ends that note only, so
two channels on one key are two notes. With `voices: N` (a `voices:` template), a note-on takes
the voice holding the same note (a restrike), else a free voice (never used, else released
longest ago: a released voice keeps its note and rings on), else it steals the voice holding
the oldest note; so with more voices than notes sounding nothing is stolen, with fewer the
oldest note is. Every change falls at its event's sample, ⌈t·rate⌉; a voice whose gate is up
when it takes a new note (restruck, stolen) shows the onset with a one-sample dip *before* it:
gate 0 at the sample before the note-on, 1 from the note-on's sample, so a pluck or an envelope
starts again on time. A note-off and a note-on at one sample, in either order, leave the new
note sounding (the note-off ends the note begun earlier; a note struck and released at one
sample sounds for that sample). Pitch bend, channel pressure and CC 74 reach the voices of their
channel, key pressure the voice holding the key. With `voice: 0` the block follows the newest
note held (a release falls back to the newest still held, legato). A file, a live port and a
replayed take give the same columns for the same events: a live event is placed within its
block (a latency of one block and one sample) and a file is read one sample ahead. `slide` is
CC 74 of the note's channel / 127 (64/127, the middle, until one arrives).

MPE (hapticgraph.devices.mpe; `mpe: lower|upper|auto` in a voices: template, channel 0): each
note on a channel of the zone is a voice. A note on a member channel sounds its key plus its
channel's bend times the members' range (±48 semitones) plus the master channel's bend times
the master's range (±2); RPN 0 on the master channel sets the master's range, on a member
channel every member's. Its pressure (channel pressure) and slide (CC 74) are its channel's, or
the master channel's when that spoke last; a note-on takes its channel's values, which return to
0, 0 and 64/127 when the channel's last note ends. A released note keeps its own bend, pressure
and slide (what its channel sends next sets up the channel's next note); the master channel
still reaches it. The lower zone is master channel 1 and members 2 … N+1, the upper master 16
and members 15 … 16−N; N = 15 (`lower`, `auto`: the lower zone; `upper`: the upper) until an MPE
Configuration Message (RPN 6 on a master channel; 0 members: no zone) says otherwise; a zone
that takes the other's channels shrinks it, and the notes of channels that change zone end. A
note on the master channel sounds the master's bend alone and takes key pressure; all-notes-off
on the master channel ends every note of the zone. At one sample: RPN first, then notes, then
bend, pressure and slide."""
    midi_gate = External(doc="1 while a key is held")
    midi_note = External(doc="the sounding note number (last-note priority)")
    midi_bend = External(doc="pitch wheel, −1 … 1")
    midi_velocity = External(doc="on-velocity / 127")
    midi_pressure = External(doc="aftertouch / 127")
    midi_slide = External(doc="CC 74 / 127")
    midi_detune = External(doc="MPE: the note's member and master channel bends, each times its range [semitones]")

    @classmethod
    def check(cls, p, fs):
        if p.voice > p.voices:
            yield "voice", f"voice {p.voice} of a group of {p.voices}: voices are numbered 1 … {p.voices}"
        if p.mpe != "off" and p.voice == 0:
            yield "mpe", (f"mpe: {p.mpe} plays each note as a voice: put this midi_note in a voices: template "
                          "(count: 1 for one voice)")
        if p.mpe != "off" and p.channel != 0:
            yield "channel", f"with mpe: {p.mpe} the zone says which channels play: leave channel 0"

    @staticmethod
    def output(midi_gate, midi_note, midi_bend, midi_velocity, midi_pressure, midi_slide, midi_detune,
               bend_range):
        freq = 440.0 * math.pow(2.0, (midi_note - A4 + midi_bend * bend_range + midi_detune) / 12.0)
        return midi_gate, freq, midi_velocity, midi_pressure, midi_slide


class MidiCC(Block, name="midi_cc"):
    """u = value/127; target = min + u·(max − min) (linear) or min·(max/min)^u; out[n] = out[n−1] + a·(target − out[n−1]), a = 1 − exp(−1/(smooth·fs))."""

    y = Out(name="out", doc="the controller's value, from min until the first message")
    device = Param("", refers="controller", doc=DEVICE_DOC)
    channel = Param(0, minimum=0, maximum=16, doc="MIDI channel 1–16; 0: omni (every channel)")
    number = Param(1, minimum=0, maximum=127, doc="controller number (1 mod wheel, 7 volume, 74 brightness …)")
    min = Param(0.0, minimum=-1e12, maximum=1e12, live=False, doc="the output at controller value 0")
    max = Param(1.0, minimum=-1e12, maximum=1e12, live=False, doc="the output at controller value 127")
    curve = Param("linear", choices=("linear", "exponential"))
    smooth = Param(0.0, unit="s", minimum=0.0, maximum=10.0, live=False,
                   doc="time constant of a one-pole smoother (0: none)")
    midi_cc = External(doc="the controller's value / 127 (0 before the first message)")
    y1 = State(lambda p, fs: p.min, doc="the previous output")

    @classmethod
    def check(cls, p, fs):
        if p.curve == "exponential" and not p.min * p.max > 0.0:
            yield "curve", "an exponential curve needs min and max non-zero and of one sign"

    structure = ("expo",)      # the curve is a choice; the range and the smoothing are data

    @staticmethod
    def derive(p, fs):
        expo = p.curve == "exponential"
        return {"lo": float(p.min), "span": float(p.max - p.min), "expo": expo,
                "log_ratio": math.log(p.max / p.min) if expo else 0.0,
                "a": 1.0 - math.exp(-1.0 / (p.smooth * fs)) if p.smooth > 0.0 else 1.0}

    @staticmethod
    def output(midi_cc, y1, lo, span, expo, log_ratio, a):
        target = lo * math.exp(midi_cc * log_ratio) if expo else lo + midi_cc * span
        return y1 + a * (target - y1)

    @staticmethod
    def update(y):
        return y


class OscIn(Block, name="osc_in"):
    """out[n] = the last number received at `address` (0 before the first message)."""

    y = Out(name="out", doc="the value held since the last message")
    device = Param("", refers="controller", doc=DEVICE_DOC)
    address = Param("/value", doc="the OSC address pattern's exact address, e.g. /fader/1")
    index = Param(0, minimum=0, maximum=63, doc="which argument of the message")
    osc_value = External(doc="the last value received")

    @staticmethod
    def output(osc_value):
        return osc_value
