"""Voice allocation (hapticgraph.devices.voices): a free voice first (never used, else released
longest ago), else the oldest note stolen; a released voice keeps its note (it rings on) until
reused; every change at its event's exact sample, across block boundaries."""
import mido
import numpy as np
import pytest
from hapticgraph.devices.voices import BEND, GATE, NOTE, PRESSURE, VELOCITY, Allocator

import hapticgraph


class Song:
    """A hub stand-in: (absolute sample, message) events delivered block by block."""

    def __init__(self, events):
        self.events_at = sorted(events, key=lambda e: e[0])

    def events(self, t0, n):
        return [(s - t0, m) for s, m in self.events_at if t0 <= s < t0 + n]

    def peek(self, t):
        return [m for s, m in self.events_at if s == t]


def on(key, velocity=100, channel=0):
    return mido.Message("note_on", note=key, velocity=velocity, channel=channel)


def off(key, channel=0):
    return mido.Message("note_off", note=key, channel=channel)


def columns(events, count=3, n=200, block=64, channel=None):
    """n samples × count voices × 5 columns, computed block by block."""
    alloc = Allocator(Song(events), channel, count)
    return np.concatenate([alloc.block(t0, min(block, n - t0)).transpose(1, 0, 2).copy()
                           for t0 in range(0, n, block)])


def test_free_voice_first_never_used_then_released_longest_ago():
    c = columns([(10, on(60)), (20, on(64)), (30, off(60)), (40, on(67)), (50, off(64)), (60, on(72)),
                 (70, on(74))])
    assert c[10:, 0, NOTE][0] == 60 and c[20, 1, NOTE] == 64
    assert c[40, 2, NOTE] == 67            # voice 3 was never used: it goes before the released voice 1
    assert c[60, 0, NOTE] == 72            # voice 1 (released at 30) before voice 2 (released at 50)
    assert c[70, 1, NOTE] == 74 and c[70, 1, GATE] == 1.0
    assert c[199, 2, NOTE] == 67 and c[199, 2, GATE] == 1.0   # the held voice is never taken while one is free


def test_steal_the_oldest_note():
    c = columns([(10, on(60)), (11, on(64)), (12, on(67)), (100, on(72)), (150, on(74))])
    # voice 1 held the oldest note: at sample 100 its freq changes; its gate dips at the sample before
    assert (c[99, 0, NOTE], c[100, 0, NOTE]) == (60, 72)
    assert list(c[98:103, 0, GATE]) == [1.0, 0.0, 1.0, 1.0, 1.0]
    assert c[100, 0, VELOCITY] == 100 / 127
    assert (c[149, 1, NOTE], c[150, 1, NOTE]) == (64, 74)     # then voice 2 (64), the next oldest
    assert list(c[148:151, 1, GATE]) == [1.0, 0.0, 1.0]
    assert np.all(c[:, 2, GATE][12:] == 1.0) and np.all(c[12:, 2, NOTE] == 67)   # voice 3 untouched


def test_a_released_voice_rings_on_until_reused():
    c = columns([(10, on(60, velocity=64)), (20, on(64)), (30, off(60)), (90, on(67)), (120, on(69))],
                count=2)
    # released: the gate falls, the note and velocity stay (the string keeps its pitch and rings)
    assert c[29, 0, GATE] == 1.0 and np.all(c[30:90, 0, GATE] == 0.0)
    assert np.all(c[30:90, 0, NOTE] == 60) and np.all(c[30:90, 0, VELOCITY] == 64 / 127)
    assert c[90, 0, NOTE] == 67 and (c[89, 0, GATE], c[90, 0, GATE]) == (0.0, 1.0)   # reused: a plain rise
    assert c[120, 1, NOTE] == 69          # all held: the oldest (64 on voice 2) is stolen


def test_a_repeated_key_restrikes_its_own_voice_and_a_stale_note_off_is_ignored():
    c = columns([(10, on(60)), (20, on(64)), (30, on(60)), (40, on(67)), (41, on(69)), (60, off(60)),
                 (70, off(64))], count=3)
    assert list(c[28:31, 0, GATE]) == [1.0, 0.0, 1.0] and c[30, 0, NOTE] == 60
    # 69 stole voice 2 (64, now the oldest); 64's note-off then finds no voice and changes nothing
    assert c[41, 1, NOTE] == 69 and np.all(c[42:, 1, GATE] == 1.0)
    assert np.all(c[60:, 0, GATE] == 0.0)


@pytest.mark.parametrize("at", [63, 64, 65])
def test_steal_at_a_block_boundary_dips_before_its_sample(at):
    """The dip before an onset at a block's first sample falls in the block before (look-ahead)."""
    c = columns([(0, on(60)), (at, on(62))], count=1, n=128, block=64)
    assert list(c[at - 2:at + 2, 0, GATE]) == [1.0, 0.0, 1.0, 1.0]
    assert c[at - 1, 0, NOTE] == 60 and c[at, 0, NOTE] == 62


def test_bend_pressure_and_all_notes_off_reach_their_channel_only():
    events = [(5, on(60)), (6, on(64, channel=2)), (10, mido.Message("pitchwheel", pitch=4096)),
              (12, mido.Message("polytouch", note=60, value=127)),
              (13, mido.Message("polytouch", note=64, value=127)),       # channel 1 holds no 64
              (14, mido.Message("aftertouch", value=0)),
              (16, mido.Message("aftertouch", value=127, channel=2)),
              (18, mido.Message("pitchwheel", pitch=-8192, channel=3)), (19, on(67, channel=3)),
              (20, mido.Message("control_change", control=123, value=0))]
    c = columns(events, count=3)
    assert np.all(c[10:, 0, BEND] == 0.5) and np.all(c[:, 1, BEND] == 0.0)   # channel 1's bend: its voice only
    assert c[12, 0, PRESSURE] == 1.0 and c[13, 1, PRESSURE] == 0.0 and c[14, 0, PRESSURE] == 0.0
    assert c[16, 1, PRESSURE] == 1.0 and c[16, 0, PRESSURE] == 0.0
    assert c[19, 2, BEND] == -1.0                       # a note takes its channel's bend at its onset
    assert np.all(c[20:, 0, GATE] == 0.0) and np.all(c[20:, 1:, GATE] == 1.0)   # CC 123 of channel 1
    only = columns(events, count=2, channel=2)
    assert only[6, 0, NOTE] == 64 and np.all(only[:, 1, GATE] == 0.0) and np.all(only[:, 0, BEND] == 0.0)


@pytest.mark.parametrize("chunk", [1, 64, 1000])
def test_note_ons_at_their_exact_samples_in_a_patch(write_patch, tmp_path, chunk):
    """Through the loader, the MIDI file reader and the kernel: every block size alike."""
    from hapticgraph.devices.midi import write_midi_file
    events = [(100, on(60)), (101, on(64)), (102, on(67)), (150, on(72)), (151, off(64)), (199, on(74))]
    write_midi_file(tmp_path / "n.mid", events, 48000)
    patch = hapticgraph.load(write_patch("""
        hapticgraph: 1
        rate: 48000
        devices:
          keys: {driver: midi, file: n.mid}
        blocks:
          out: {type: audio_out, channels: 1}
        voices:
          count: 3
          prefix: key
          blocks:
            note: {type: midi_note, device: keys}
          connect:
            - note.gate -> out.ch0
        """))
    probes = [f"key{k}_note.{p}" for k in (1, 2, 3) for p in ("gate", "freq")]
    r = hapticgraph.render(patch, 0.005, probes=probes, chunk=chunk)
    gate = np.stack([r.probes[f"key{k}_note.gate"] for k in (1, 2, 3)], axis=1)
    assert list(gate[99]) == [0, 0, 0] and list(gate[100]) == [1, 0, 0] and list(gate[102]) == [1, 1, 1]
    assert list(gate[149]) == [0, 1, 1] and list(gate[150]) == [1, 1, 1]       # 72 steals voice 1: dip before
    assert list(gate[151]) == [1, 0, 1]                                         # 64 released
    assert list(gate[199]) == [1, 1, 1] and r.probes["key2_note.freq"][199] == pytest.approx(440 * 2 ** (5 / 12))
    np.testing.assert_array_equal(r.audio[:, 0], gate.sum(axis=1))             # the voices' gates sum


def _random_messages(rng, count):
    """Note-ons, note-offs (some as velocity 0) and bends on two channels and three keys."""
    out = []
    for _ in range(count):
        key, channel, kind = int(rng.choice([60, 62, 64])), int(rng.integers(0, 2)), rng.integers(0, 4)
        out.append(on(key, channel=channel) if kind == 0 else off(key, channel=channel) if kind == 1 else
                   on(key, velocity=0, channel=channel) if kind == 2 else
                   mido.Message("pitchwheel", pitch=int(rng.integers(-8192, 8192)), channel=channel))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_live_events_give_the_columns_a_file_of_them_gives(seed):
    """A live hub (its clock faked: events stamped inside each block's interval, bursts sharing a
    stamp) logs each event at the sample it placed it; those events as a file give the same
    voices, sample for sample, in any block size."""
    from hapticgraph.devices.events import Hub
    rng, rate, n = np.random.default_rng(seed), 48000, 64
    live, now = Hub("keys"), [0.0]
    live.clock = lambda: now[0]
    live.start(rate)
    live.log = []
    alloc, blocks = Allocator(live, None, 3), []
    for t0 in range(0, 64 * n, n):
        stamps = np.sort(rng.uniform(now[0], now[0] + n / rate, int(rng.integers(0, 5))))
        for stamp in stamps:
            for message in _random_messages(rng, int(rng.integers(1, 3))):
                live.post(message, float(stamp))
        now[0] += n / rate
        blocks.append(alloc.block(t0, n).transpose(1, 0, 2).copy())
    played = np.concatenate(blocks)
    assert len(live.log) > 50 and len({s for s, _ in live.log}) < len(live.log)    # bursts at one sample
    assert min(s - 64 * (s // 64) for s, _ in live.log if s >= 64) >= 0
    for block in (1, 64, 100):
        from_file = Allocator(Hub("song", timed=sorted(live.log, key=lambda e: e[0])), None, 3)
        from_file.hub.start(rate)
        cols = np.concatenate([from_file.block(t0, min(block, len(played) - t0)).transpose(1, 0, 2).copy()
                               for t0 in range(0, len(played), block)])
        np.testing.assert_array_equal(cols, played)


def test_two_channels_on_one_key_are_two_notes():
    """Issue 24's chorale: channel 2 releases key 55 at the sample channel 1 strikes it (listed
    first); then both hold 57 and channel 1 lets go first; then both strike 59 at one sample."""
    c = columns([(10, on(55, channel=1)), (50, on(55)), (50, off(55, channel=1)),
                 (60, on(57)), (62, on(57, channel=1)), (80, off(57)), (100, off(57, channel=1)),
                 (120, on(59)), (120, on(59, channel=1))], count=4, n=160)
    at = {k: np.flatnonzero((c[:, :, GATE] > 0) & (c[:, :, NOTE] == k)) for k in (55, 57, 59)}
    sounding = {k: np.unique(np.flatnonzero(((c[:, :, GATE] > 0) & (c[:, :, NOTE] == k)).any(axis=1)))
                for k in (55, 57, 59)}
    assert list(sounding[55]) == list(range(10, 160))      # the new 55 goes on: only its channel's off ends it
    assert list(sounding[57]) == list(range(60, 100))      # held until the second channel lets go
    assert all(len(at[k]) for k in at)
    v59 = np.flatnonzero(c[120, :, NOTE] == 59)
    assert len(v59) == 2 and np.all(c[119, v59, GATE] == 0.0) and np.all(c[120, v59, GATE] == 1.0)


@pytest.mark.parametrize("order", ["off first", "on first"])
def test_a_note_off_and_a_note_on_at_one_sample_leave_the_new_note(order):
    events = [(10, on(60, velocity=40)), (30, off(60)), (30, on(60, velocity=90))]
    if order == "on first":
        events[1], events[2] = events[2], events[1]
    c = columns(events, count=2, n=64)
    gate = (c[:, :, GATE] > 0) & (c[:, :, NOTE] == 60)
    assert gate[10:].any(axis=1).all()                       # heard throughout: the old note to 29, the new from 30
    new = int(np.flatnonzero(c[30, :, VELOCITY] == 90 / 127)[0])
    assert (c[29, new, GATE], c[30, new, GATE]) == (0.0, 1.0) and np.all(c[30:, new, GATE] == 1.0)


def test_a_restrike_starts_at_its_own_sample_with_the_dip_before():
    c = columns([(10, on(60)), (30, on(60, velocity=20)), (31, on(60, velocity=30))], count=1, n=40)
    assert list(c[27:33, 0, GATE]) == [1.0, 1.0, 0.0, 0.0, 1.0, 1.0]   # 30's dip at 29; 31's at 30 (30 lost)
    assert c[29, 0, VELOCITY] == 100 / 127 and c[31, 0, VELOCITY] == 30 / 127
