"""Write the MPE gesture files of this folder with mido (`python tests/data/mpe/make_gestures.py`).

Each file is a type 1 Standard MIDI File, 480 ticks per beat at 120 beats per minute: one tick is
1/960 s, 50 samples at 48 kHz, so every event falls on a whole sample (tests/devices/test_mpe.py
checks the outputs there). Channels are numbered from 0 here as in mido (MIDI channel 1 is 0).
"""
import pathlib

import mido

HERE = pathlib.Path(__file__).resolve().parent
TPB = 480


def cc(channel, control, value):
    return mido.Message("control_change", channel=channel, control=control, value=value)


def rpn(channel, number, msb, lsb=None):
    """Registered parameter `number` set to msb (and lsb): CC 101, 100, 6 (and 38), then RPN null."""
    out = [cc(channel, 101, 0), cc(channel, 100, number), cc(channel, 6, msb)]
    if lsb is not None:
        out.append(cc(channel, 38, lsb))
    return out + [cc(channel, 101, 127), cc(channel, 100, 127)]


def mcm(master, members):
    """The MPE Configuration Message (RPN 6) on a master channel (0: lower zone, 15: upper zone)."""
    return rpn(master, 6, members)


def on(channel, key, velocity=100):
    return mido.Message("note_on", channel=channel, note=key, velocity=velocity)


def off(channel, key):
    return mido.Message("note_off", channel=channel, note=key)


def bend(channel, pitch):
    return mido.Message("pitchwheel", channel=channel, pitch=pitch)


def pressure(channel, value):
    return mido.Message("aftertouch", channel=channel, value=value)


LOWER = [   # the lower zone, 15 member channels: master 0, members 1 … 15
    (0, mcm(0, 15)),
    (10, [bend(1, 0), cc(1, 74, 64), pressure(1, 0), on(1, 60, 100)]),   # set up, then strike
    (20, [on(2, 64, 80)]),
    (30, [bend(1, 4096)]),                      # +0.5 of ±48: +24 semitones, note 60 only
    (40, [pressure(1, 127)]),                   # note 60's pressure
    (50, [cc(2, 74, 127)]),                     # note 64's slide
    (60, [bend(0, 4096)]),                      # master: +0.5 of ±2, every note
    (70, rpn(0, 0, 12, 0)),                     # master range ±12: +6
    (80, rpn(2, 0, 24, 0)),                     # member range ±24 (zone-wide): note 60 +12
    (90, [off(1, 60)]),                         # released: keeps its pitch
    (95, [bend(1, -8192)]),                     # the next note's set-up on channel 1: not the released one
    (100, [on(1, 67, 90)]),                     # −24 + 6
    (110, [pressure(0, 100)]),                  # master pressure: every voice
    (115, [bend(0, 0)]),                        # master back to the middle
    (120, [cc(0, 123, 0)]),                     # master all-notes-off: the zone's notes end
    (130, [on(1, 62, 70)]),                     # channel 1 was reset when its note ended
    (140, [on(0, 48, 60)]),                     # a note on the master channel
    (150, [bend(0, -8192)]),                    # −12 for both (master range ±12)
    (160, [mido.Message("polytouch", channel=0, note=48, value=64)]),
    (170, [off(0, 48), off(1, 62)]),
]

UPPER = [   # the upper zone, 3 member channels: master 15, members 14, 13, 12
    (0, mcm(15, 3)),
    (10, [on(14, 60), on(11, 62), on(0, 64)]),  # channel 11 and 0 are in no upper zone: ignored
    (20, [on(12, 65), bend(12, 8191)]),
    (30, [bend(15, -4096)]),                    # the upper master: −1
    (40, [bend(0, 8191)]),                      # the lower master: not this zone
    (50, [off(14, 60), off(12, 65), off(11, 62), off(0, 64)]),
]

BOTH = [    # both zones, from the MPE Configuration Messages
    (0, mcm(0, 15) + mcm(15, 3)),               # the upper zone takes 3 members: the lower shrinks to 11
    (10, [on(1, 60), on(14, 72), on(12, 67)]),  # channel 12 is the upper zone's now
    (20, [bend(0, 4096), bend(15, -8192)]),     # lower +1, upper −2
    (30, [on(11, 55)]),                         # the lower zone's last member channel
    (40, mcm(15, 0)),                           # the upper zone off: its notes end
    (50, [on(13, 74)]),                         # no zone: ignored
    (60, [off(1, 60), off(11, 55), off(13, 74)]),
]

FILES = {"lower_zone.mid": LOWER, "upper_zone.mid": UPPER, "both_zones.mid": BOTH}


def midi_file(events):
    """A type 1 file: a tempo track, and the events (tick, [messages]) in one track."""
    tempo = mido.MidiTrack([mido.MetaMessage("set_tempo", tempo=500000, time=0),
                            mido.MetaMessage("end_of_track", time=0)])
    track, last = mido.MidiTrack(), 0
    for tick, messages in events:
        for k, m in enumerate(messages):
            track.append(m.copy(time=tick - last if k == 0 else 0))
        last = tick
    track.append(mido.MetaMessage("end_of_track", time=0))
    mid = mido.MidiFile(type=1, ticks_per_beat=TPB)
    mid.tracks += [tempo, track]
    return mid


def write(folder=HERE):
    for name, events in FILES.items():
        midi_file(events).save(pathlib.Path(folder) / name)


if __name__ == "__main__":
    write()
