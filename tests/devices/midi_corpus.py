"""An independent model of a Standard MIDI File's notes, and a check that a rendered `voices:`
group of `midi_note` blocks sounds each of them whole (tests/data/midi/README.md lists the files).

The model reads mido's parsed messages, merged in file order, and applies the tempo map with
exact fractions (not hapticgraph's reader). A note belongs to its channel and key: it opens at a
note-on and closes at the first note-off (or note-on of velocity 0, or all-notes-off of its
channel) at or after it; a note-off at the tick a note of its key opened closes the note opened
before, if one is open, else that one (a note of no length). A note-on of a note already open
restrikes it: the open note ends there, a new one begins. A note lasts the samples
⌈t_on·rate⌉ … ⌈t_off·rate⌉ − 1.

"Heard whole": at every sample of the note, some voice has its gate up and sounds the note's key
(within the bend range, if the note's channel bends at all), except that a note ended by its own
restrike may lose its last sample (the restruck voice's dip); its onset is a rising gate at
⌈t_on·rate⌉ of a voice at its key.

`python tests/devices/midi_corpus.py [SECONDS]` prints notes heard whole / notes, file by file.
"""
import math
import pathlib
import sys
import tempfile
from dataclasses import dataclass
from fractions import Fraction

import mido
import numpy as np

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "midi"
RATE = 44100
VOICES = 48
BLOCK = 4096
BEND_RANGE = 2.0
ALL_OFF = (120, 123)

PATCH = """
hapticgraph: 1
rate: {rate}
devices:
  song: {{driver: midi, file: {file}}}
blocks:
  out: {{type: audio_out, channels: 1}}
voices:
  count: {voices}
  blocks:
    note: {{type: midi_note, device: song, channel: {channel}, bend_range: {bend}}}
  connect:
    - note.gate -> out.ch0
"""


@dataclass
class Note:
    channel: int
    key: int
    on: int             # first sample
    off: int            # first sample after it
    restruck: bool      # ended by a note-on of its own channel and key


def corpus():
    return sorted(DATA.glob("*.mid"))


def tempo_map(mid):
    """seconds(tick): the file's set_tempo events, in file order, applied exactly."""
    changes, tick = [(0, 500000)], 0
    for message in mido.merge_tracks(mid.tracks):
        tick += message.time
        if message.type == "set_tempo":
            changes.append((tick, message.tempo))
    tpb = Fraction(mid.ticks_per_beat)

    def seconds(at):
        total = Fraction(0)
        for (start, tempo), (end, _) in zip(changes, changes[1:] + [(math.inf, 0)]):
            if at <= start:
                break
            total += Fraction(min(at, end) - start) * tempo / (tpb * 1_000_000)
        return total
    return seconds


def notes(path, rate=RATE):
    """Every note of the file as a Note, and the channels that bend."""
    mid = mido.MidiFile(path)
    seconds, tick = tempo_map(mid), 0
    opened, out, bends = {}, [], set()        # (channel, key) -> its on tick
    restruck = {}                              # (channel, key) -> (tick, index in out) of its last restrike

    def close(note, at, by_restrike=False):
        if note in opened:
            out.append([*note, opened.pop(note), at, by_restrike])
            if by_restrike:
                restruck[note] = (at, len(out) - 1)
    for message in mido.merge_tracks(mid.tracks):
        tick += message.time
        kind, note = message.type, (getattr(message, "channel", None), getattr(message, "note", None))
        if kind == "note_on" and message.velocity > 0:
            if opened.get(note, tick) != tick:
                close(note, tick, by_restrike=True)
            opened.setdefault(note, tick)
        elif kind in ("note_off", "note_on"):
            if opened.get(note) == tick and restruck.get(note, (None,))[0] == tick:
                out[restruck.pop(note)[1]][4] = False      # the off of the note before: it ends here anyway
            else:
                close(note, tick)
        elif kind == "control_change" and message.control in ALL_OFF:
            for held in [n for n in opened if n[0] == message.channel]:
                close(held, tick)
        elif kind == "pitchwheel" and message.pitch != 0:
            bends.add(message.channel)
    for note in list(opened):
        close(note, tick)

    def sample(t):
        return math.ceil(seconds(t) * rate)
    return [Note(c, k, sample(a), sample(b), r) for c, k, a, b, r in out], bends


def session(folder, path, rate, voices, channel):
    """A Session of the corpus patch playing the file, its probes: each voice's gate and freq."""
    import hapticgraph
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.engine import Runner
    (folder / "song.mid").write_bytes(pathlib.Path(path).read_bytes())
    (folder / "p.yaml").write_text(PATCH.format(rate=rate, file="song.mid", voices=voices, channel=channel,
                                                bend=BEND_RANGE))
    patch = hapticgraph.load(folder / "p.yaml")
    probes = [f"v{k}_note.{p}" for k in range(1, voices + 1) for p in ("gate", "freq")]
    return Runner(patch, probes, open_drivers(patch), blocksize=BLOCK)


def check(block, c0, notes, found, before, bends, bend_range=BEND_RANGE):
    """Mark in `found` (notes × [whole, onset]) what samples c0 … of `block` (gates, pitches)
    show of the notes that overlap it (see the module's doc); `before`: the gates at c0 − 1."""
    gates, pitches = block
    c1 = c0 + len(gates)
    for k, note in enumerate(notes):
        end = note.off - (1 if note.restruck else 0)
        if note.on >= c1 or end <= c0:
            continue
        a, b = max(note.on, c0) - c0, min(end, c1) - c0
        tolerance = bend_range + 1e-9 if note.channel in bends else 1e-9
        at_key = (gates[a:b] > 0.0) & (np.abs(pitches[a:b] - note.key) <= tolerance)
        found[k, 0] &= bool(at_key.any(axis=1).all())
        if c0 <= note.on:
            prev = gates[a - 1] if a > 0 else before
            found[k, 1] = bool((at_key[0] & (prev == 0.0)).any())


def measure(path, seconds, rate=RATE, voices=VOICES, channel=0):
    """(notes heard whole, notes with their onset at their sample, notes) of the file's first
    `seconds`; `channel` 1–16 renders that channel only (0: omni)."""
    every, bends = notes(path, rate)
    length = int(round(seconds * rate))
    mine = [n for n in every if n.on < length and n.off > n.on + (1 if n.restruck else 0)
            and (channel == 0 or n.channel == channel - 1)]
    found = np.ones((len(mine), 2), dtype=bool)
    before = np.zeros(voices)
    with tempfile.TemporaryDirectory() as tmp:
        run = session(pathlib.Path(tmp), path, rate, voices, channel)
        try:
            for c0 in range(0, length, BLOCK):
                rec = run.process(min(BLOCK, length - c0))
                gates, pitches = rec[:, 1::2], 69.0 + 12.0 * np.log2(rec[:, 2::2] / 440.0)
                check((gates, pitches), c0, mine, found, before, bends)
                before = gates[-1].copy()
        finally:
            run.stop()
    return int(found[:, 0].sum()), int(found[:, 1].sum()), len(mine)


def polyphony(path, rate=RATE):
    """The most notes sounding at one sample."""
    every, _ = notes(path, rate)
    edges = sorted([(n.on, 1) for n in every if n.off > n.on] + [(n.off, -1) for n in every if n.off > n.on])
    level = peak = 0
    for _, step in edges:
        level += step
        peak = max(peak, level)
    return peak


if __name__ == "__main__":
    span = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    total = [0, 0, 0]
    for p in corpus():
        whole, onsets, count = measure(p, span)
        total = [a + b for a, b in zip(total, (whole, onsets, count))]
        print(f"{p.name:40s} {whole:5d} / {count:5d} whole, {onsets:5d} onsets at their sample")
    print(f"{'corpus':40s} {total[0]:5d} / {total[2]:5d} whole, {total[1]:5d} onsets at their sample")
