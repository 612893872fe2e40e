"""Real Standard MIDI Files (tests/data/midi, README there) played through a `voices:` group of
`midi_note`: against an independent model of each file (tests/devices/midi_corpus.py), every note
is heard for its whole length by a voice at its key, and starts at ⌈t·rate⌉."""
import collections
import pathlib

import mido
import pytest
from midi_corpus import DATA, corpus, measure, notes, polyphony

SECONDS = 10.0           # of each file (the whole corpus over 20 s: `python tests/devices/midi_corpus.py 20`)
FILES = corpus()


def running_status(path):
    """How many channel messages of the file's tracks reuse the status byte before them."""
    data, at, count = pathlib.Path(path).read_bytes(), 14, 0
    while at < len(data):
        end, at, status = at + 8 + int.from_bytes(data[at + 4:at + 8], "big"), at + 8, None
        while at < end:
            at = _skip_varlen(data, at)                       # the delta time
            byte = data[at]
            if byte in (0xFF, 0xF0, 0xF7):                    # meta or sysex: a length, then the data
                at += 2 if byte == 0xFF else 1
                length_end = _skip_varlen(data, at)
                at = length_end + _varlen(data[at:length_end])
                continue
            if byte & 0x80:
                status, at = byte, at + 1
            else:
                count += 1
            at += 1 if status & 0xF0 in (0xC0, 0xD0) else 2
        at = end
    return count


def _skip_varlen(data, at):
    while data[at] & 0x80:
        at += 1
    return at + 1


def _varlen(raw):
    value = 0
    for byte in raw:
        value = (value << 7) | (byte & 0x7F)
    return value


def features(path):
    """What a file exercises, from mido's parsed messages."""
    mid = mido.MidiFile(path)
    seen, held, tick, onsets = set(), collections.Counter(), 0, collections.Counter()
    channels = set()
    for m in mido.merge_tracks(mid.tracks):
        tick += m.time
        if m.type == "set_tempo" and tick > 0:
            seen.add("tempo changes")
        elif m.type == "pitchwheel" and m.pitch:
            seen.add("pitch bend")
        elif m.type == "note_on" and m.velocity > 0:
            channels.add(m.channel)
            onsets[tick] += 1
            if any(held[(c, m.note)] for c in range(16) if c != m.channel):
                seen.add("one key on two channels")
            if held[(m.channel, m.note)]:
                seen.add("restrikes")
            held[(m.channel, m.note)] += 1
        elif m.type in ("note_on", "note_off"):
            seen.add("velocity-0 note-offs" if m.type == "note_on" else "note-offs")
            held[(m.channel, m.note)] = 0
    seen |= {f"type {mid.type}"} | ({"several channels"} if len(channels) > 1 else set())
    seen |= {"chords"} if max(onsets.values(), default=0) > 1 else set()
    seen |= {"repeated notes"} if _repeats(path) else set()
    return seen | ({"running status"} if running_status(path) else set())


def _repeats(path):
    every, _ = notes(path)
    ends = {(n.channel, n.key, n.off) for n in every}
    return any((n.channel, n.key, n.on) in ends for n in every)


def test_the_corpus_covers_what_real_files_do():
    assert len(FILES) >= 12
    readme = (DATA / "README.md").read_text(encoding="utf-8")
    assert all(p.name in readme for p in FILES)                 # each file's source and license listed
    covered = collections.Counter(f for p in FILES for f in features(p))
    for feature in ("type 0", "type 1", "several channels", "tempo changes", "running status", "pitch bend",
                    "velocity-0 note-offs", "note-offs", "chords", "repeated notes", "restrikes",
                    "one key on two channels"):
        assert covered[feature] >= 1, feature
    assert max(polyphony(p) for p in FILES) < 48                 # VOICES: more voices than notes


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_every_note_is_heard_whole_from_its_sample(path):
    whole, onsets, count = measure(path, SECONDS)
    assert count > 0
    assert (whole, onsets) == (count, count)


@pytest.mark.parametrize("name, channel", [("music21_test17.mid", 2), ("openmsx_tttheme2.mid", 3)])
def test_one_channel_alone(name, channel):
    """`channel: N`: the notes of that channel, whole, whatever the other channels play."""
    whole, onsets, count = measure(DATA / name, SECONDS, channel=channel)
    assert count > 0 and (whole, onsets) == (count, count)


def test_the_check_sees_a_note_cut_short():
    """Too few voices for the file: the oldest notes are stolen, and the check says so."""
    whole, onsets, count = measure(DATA / "pianobooster_chord_of_c_major.mid", SECONDS, voices=2)
    assert whole < count / 2 and onsets < count                   # a chord of 3 on 2 voices: one never starts


def test_the_model_reads_notes_by_channel_and_key(tmp_path):
    """Same-tick orders, velocity-0 note-offs, restrikes and a second channel on one key."""
    track = mido.MidiTrack([
        mido.Message("note_on", note=60, velocity=90, time=0),
        mido.Message("note_on", note=60, velocity=90, channel=1, time=10),   # channel 2, same key
        mido.Message("note_on", note=60, velocity=0, time=10),                 # ends channel 1's note only
        mido.Message("note_on", note=62, velocity=90, time=0),
        mido.Message("note_on", note=62, velocity=90, time=20),                # restrike without a note-off
        mido.Message("note_on", note=64, velocity=90, time=0),
        mido.Message("note_off", note=64, time=0),                              # a note of no length
        mido.Message("note_on", note=62, velocity=80, time=10),                 # on, then the old note's off
        mido.Message("note_off", note=62, time=0),
        mido.Message("note_off", note=62, time=10),
        mido.Message("note_off", note=60, channel=1, time=0),
    ])
    mid = mido.MidiFile(type=0, ticks_per_beat=480)
    mid.tracks.append(track)
    mid.save(tmp_path / "m.mid")
    got, bends = notes(tmp_path / "m.mid", rate=960)              # one tick, one sample (120 bpm)
    assert sorted((n.channel, n.key, n.on, n.off, n.restruck) for n in got) == [
        (0, 60, 0, 20, False), (0, 62, 20, 40, True), (0, 62, 40, 50, False), (0, 62, 50, 60, False),
        (0, 64, 40, 40, False), (1, 60, 10, 60, False)]
    assert bends == set()
