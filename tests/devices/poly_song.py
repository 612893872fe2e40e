"""The notes of patches/poly_chords.mid (`python tests/devices/poly_song.py` writes it again):
an E minor chord strummed, released while it rings; an A chord of six notes and a seventh that
steals the oldest voice; every key but one released, and a last note that takes a free voice,
not the held one. 480 ticks per beat at 120 beats per minute: a tick is 1/960 s, 45.9375 samples
at 44.1 kHz, so most events fall between samples."""
import pathlib

import mido

# (tick, "on" | "off", key)
NOTES = ([(10 + 29 * k, "on", key) for k, key in enumerate((40, 47, 52, 55, 59, 64))]
         + [(480, "off", key) for key in (40, 47, 52, 55, 59, 64)]
         + [(576 + 23 * k, "on", key) for k, key in enumerate((45, 52, 57, 61, 64, 69, 73))]
         + [(1152, "off", key) for key in (52, 57, 61, 64, 73, 45)]
         + [(1248, "on", 76), (1440, "off", 69), (1440, "off", 76)])


def song():
    mid = mido.MidiFile(type=0, ticks_per_beat=480)
    track = mido.MidiTrack()
    last = 0
    for tick, kind, key in NOTES:
        message = mido.Message("note_on", note=key, velocity=100) if kind == "on" else \
            mido.Message("note_off", note=key, velocity=64)
        track.append(message.copy(time=tick - last))
        last = tick
    mid.tracks.append(track)
    return mid


if __name__ == "__main__":
    song().save(pathlib.Path(__file__).resolve().parents[2] / "patches" / "poly_chords.mid")
