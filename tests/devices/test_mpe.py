"""MPE keyboards (`midi_note` with `mpe: lower|upper|auto` in a `voices:` template): member channels
carry each note's pitch bend (±48 semitones until an RPN 0 says otherwise), pressure and slide
(CC 74); the master channel's bend, pressure and slide reach every voice of its zone; the zones
follow the MPE Configuration Message (RPN 6). Played from the Standard MIDI Files of
tests/data/mpe (written with mido by make_gestures.py there), every event at its exact sample."""
import importlib.util
import math

import mido
import numpy as np
import pytest

import hapticgraph
from hapticgraph import PatchError
from project_env import ROOT

DATA = ROOT / "tests" / "data" / "mpe"
RATE = 48000
S = 50                 # samples per tick in the gesture files (480 ticks per beat, 120 bpm, 48 kHz)
VOICES = 4
PORTS = ("gate", "freq", "velocity", "pressure", "slide")
PATCH = """
hapticgraph: 1
rate: 48000
devices:
  keys: {{driver: midi, file: {file}}}
blocks:
  out: {{type: audio_out, channels: 1}}
voices:
  count: {voices}
  blocks:
    note: {{type: midi_note, device: keys, mpe: {mpe}}}
  connect:
    - note.gate -> out.ch0
"""


def gestures():
    spec = importlib.util.spec_from_file_location("make_gestures", DATA / "make_gestures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def play(write_patch, name, mpe, seconds=0.2, voices=VOICES, engine="compiled", chunk=1000):
    """{port: samples × voices} of the gesture file `name` played by a voices: group."""
    path = write_patch(PATCH.format(file=DATA / name, voices=voices, mpe=mpe))
    probes = [f"v{k}_note.{p}" for p in PORTS for k in range(1, voices + 1)]
    r = hapticgraph.render(hapticgraph.load(path), seconds, probes=probes, engine=engine, chunk=chunk)
    return {p: np.stack([r.probes[f"v{k}_note.{p}"] for k in range(1, voices + 1)], axis=1) for p in PORTS}


def struck(r, tick):
    """The voice whose gate rises at the tick's sample."""
    at = tick * S
    rising = [v for v in range(r["gate"].shape[1]) if r["gate"][at, v] == 1.0 and r["gate"][at - 1, v] == 0.0]
    assert len(rising) == 1, (tick, rising)
    return rising[0]


def offset(r, v, at, key):
    """Voice v's pitch at sample `at` in semitones from `key`."""
    return 12.0 * math.log2(r["freq"][at, v] / 440.0) + 69.0 - key


def near(value):
    return pytest.approx(value, abs=1e-9)


def test_the_gesture_files_are_what_the_script_writes(tmp_path):
    gestures().write(tmp_path)
    for name in ("lower_zone.mid", "upper_zone.mid", "both_zones.mid"):
        assert (tmp_path / name).read_bytes() == (DATA / name).read_bytes(), name
    readme = (DATA / "README.md").read_text(encoding="utf-8")
    assert all(name in readme for name in ("lower_zone.mid", "upper_zone.mid", "both_zones.mid", "make_gestures.py"))


def test_lower_zone_member_and_master_channels(write_patch):
    r = play(write_patch, "lower_zone.mid", "lower")
    a, b = struck(r, 10), struck(r, 20)
    assert r["gate"][:10 * S].max() == 0.0
    assert offset(r, a, 10 * S, 60) == near(0) and r["velocity"][10 * S, a] == 100 / 127
    assert r["slide"][10 * S, a] == 64 / 127 and r["pressure"][10 * S, a] == 0.0
    assert r["velocity"][20 * S, b] == 80 / 127
    # per-note bend: ±48 semitones on a member channel, the other note untouched
    assert offset(r, a, 30 * S - 1, 60) == near(0)
    assert offset(r, a, 30 * S, 60) == near(24) and offset(r, b, 30 * S, 64) == near(0)
    # per-note pressure and slide
    assert (r["pressure"][40 * S - 1, a], r["pressure"][40 * S, a], r["pressure"][40 * S, b]) == (0.0, 1.0, 0.0)
    assert (r["slide"][50 * S - 1, b], r["slide"][50 * S, b], r["slide"][50 * S, a]) == (64 / 127, 1.0, 64 / 127)
    # the master channel's bend (±2) adds to every note's own
    assert offset(r, a, 60 * S, 60) == near(25) and offset(r, b, 60 * S, 64) == near(1)
    # RPN 0 on the master channel: its range ±12; on a member channel: every member's ±24
    assert offset(r, a, 70 * S, 60) == near(30) and offset(r, b, 70 * S, 64) == near(6)
    assert offset(r, a, 80 * S, 60) == near(18) and offset(r, b, 80 * S, 64) == near(6)
    # released: the gate falls, the note keeps its pitch; its channel's next set-up is not its own
    assert r["gate"][90 * S - 1, a] == 1.0 and r["gate"][90 * S, a] == 0.0
    assert offset(r, a, 95 * S, 60) == near(18)
    c = struck(r, 100)
    assert offset(r, c, 100 * S, 67) == near(-24 + 6) and offset(r, a, 100 * S, 60) == near(18)
    # the master channel's pressure reaches every voice of the zone
    assert all(r["pressure"][110 * S, v] == 100 / 127 for v in (a, b, c))
    assert offset(r, c, 115 * S, 67) == near(-24) and offset(r, b, 115 * S, 64) == near(0)
    # all-notes-off on the master channel ends every note of the zone
    assert r["gate"][120 * S - 1, [b, c]].tolist() == [1.0, 1.0] and r["gate"][120 * S].max() == 0.0
    # a member channel whose last note ended starts the next one from the middle
    d = struck(r, 130)
    assert offset(r, d, 130 * S, 62) == near(0)
    assert (r["pressure"][130 * S, d], r["slide"][130 * S, d]) == (0.0, 64 / 127)
    # a note on the master channel: the master's bend alone, its key pressure
    e = struck(r, 140)
    assert offset(r, e, 140 * S, 48) == near(0) and r["pressure"][140 * S, e] == 100 / 127
    assert offset(r, e, 150 * S, 48) == near(-12) and offset(r, d, 150 * S, 62) == near(-12)
    assert r["pressure"][160 * S, e] == 64 / 127 and r["pressure"][160 * S, d] == 0.0
    assert r["gate"][170 * S - 1, [d, e]].tolist() == [1.0, 1.0] and r["gate"][170 * S:].max() == 0.0


def test_upper_zone(write_patch):
    r = play(write_patch, "upper_zone.mid", "upper")
    a = struck(r, 10)
    assert r["gate"][10 * S].sum() == 1.0                  # channels 11 and 0 are in no upper zone
    b = struck(r, 20)
    assert offset(r, b, 20 * S, 65) == near(48 * 8191 / 8192)
    assert offset(r, a, 30 * S, 60) == near(-1)
    assert offset(r, b, 30 * S, 65) == near(48 * 8191 / 8192 - 1)
    assert offset(r, a, 40 * S, 60) == near(-1)       # the lower master: not this zone
    assert r["gate"][50 * S:].max() == 0.0


def test_the_other_zone_shrinks_the_lower_one(write_patch):
    """`mpe: lower` on the upper zone's file: its MCM leaves the lower zone 11 member channels."""
    r = play(write_patch, "upper_zone.mid", "lower")
    assert r["gate"][10 * S].sum() == 2.0                  # channel 11 (a member) and 0 (the master)
    lows = {round(69 + 12 * math.log2(r["freq"][10 * S, v] / 440)): v for v in range(VOICES) if r["gate"][10 * S, v]}
    assert sorted(lows) == [62, 64]
    assert r["gate"][20 * S].sum() == 2.0                  # channel 12 is the upper zone's
    for key, v in lows.items():
        assert offset(r, v, 40 * S, key) == near(2 * 8191 / 8192)


@pytest.mark.parametrize("mpe, keys", [("auto", (60, 72, 67)), ("lower", (60,)), ("upper", (72, 67))])
def test_zones_from_the_configuration_message(write_patch, mpe, keys):
    r = play(write_patch, "both_zones.mid", mpe)
    at = 10 * S
    held = sorted(round(69 + 12 * math.log2(r["freq"][at, v] / 440)) for v in range(VOICES) if r["gate"][at, v])
    assert held == sorted(keys)
    for v in range(VOICES):
        if r["gate"][20 * S, v]:
            key = round(69 + 12 * math.log2(r["freq"][at, v] / 440))
            assert offset(r, v, 20 * S, key) == near(1.0 if key == 60 else -2.0)
    lower = 30 * S
    assert (r["gate"][lower].sum() - r["gate"][lower - 1].sum()) == (0 if mpe == "upper" else 1)
    if mpe != "lower":       # the upper zone switched off: its notes end there
        assert r["gate"][40 * S - 1].sum() - r["gate"][40 * S].sum() == 2
    assert r["gate"][50 * S].sum() == r["gate"][50 * S - 1].sum()    # channel 13: no zone any more


@pytest.mark.parametrize("engine, chunk", [("compiled", 1), ("compiled", 64), ("python", 333)])
def test_every_block_size_and_both_engines_agree(write_patch, engine, chunk):
    ref = play(write_patch, "lower_zone.mid", "lower", seconds=0.19)
    got = play(write_patch, "lower_zone.mid", "lower", seconds=0.19, engine=engine, chunk=chunk)
    for p in PORTS:
        np.testing.assert_array_equal(got[p], ref[p], err_msg=p)


def test_slide_without_mpe_follows_cc74_of_the_notes_channel(write_patch, tmp_path):
    from hapticgraph.devices.midi import write_midi_file
    write_midi_file(tmp_path / "s.mid", [(10, mido.Message("note_on", note=60, velocity=90, channel=2)),
                                         (20, mido.Message("control_change", control=74, value=127, channel=1)),
                                         (30, mido.Message("control_change", control=74, value=0, channel=2))], RATE)
    path = write_patch("""
        hapticgraph: 1
        rate: 48000
        devices:
          keys: {driver: midi, file: s.mid}
        blocks:
          mono: {type: midi_note, device: keys}
          out: {type: audio_out, channels: 1}
        voices:
          count: 2
          blocks:
            note: {type: midi_note, device: keys}
          connect:
            - note.gate -> out.ch0
        """)
    r = hapticgraph.render(hapticgraph.load(path), 0.001, probes=["mono.slide", "v1_note.slide"])
    for probe in ("mono.slide", "v1_note.slide"):
        s = r.probes[probe]
        assert np.all(s[:30] == 64 / 127) and np.all(s[30:] == 0.0), probe


def _problems(write_patch, text):
    with pytest.raises(PatchError) as err:
        hapticgraph.load(write_patch(text))
    return [(p.line, p.message) for p in err.value.problems]


def test_mpe_needs_voices_and_every_channel(write_patch):
    found = _problems(write_patch, """
        hapticgraph: 1
        devices:
          keys: {driver: midi}
        blocks:
          mono: {type: midi_note, device: keys, mpe: lower}
          out: {type: audio_out, channels: 1}
        voices:
          count: 2
          blocks:
            note: {type: midi_note, device: keys, mpe: upper, channel: 3}
          connect:
            - note.gate -> out.ch0
        """)
    lines = dict(found)
    assert set(lines) == {5, 10}, found
    assert "mono" in lines[5] and "'mpe'" in lines[5] and "voices:" in lines[5]
    assert lines[10].startswith("voices: ") and "'channel'" in lines[10] and "zone" in lines[10]
    bad = _problems(write_patch, """
        hapticgraph: 1
        devices:
          keys: {driver: midi}
        voices:
          count: 2
          blocks:
            note: {type: midi_note, device: keys, mpe: middle}
        """)
    assert len(bad) == 1 and bad[0][0] == 7 and "mpe" in bad[0][1]


def test_rpn_cents_and_a_repeated_configuration_message(write_patch, tmp_path):
    """RPN 0's cents (CC 38) count; an MCM that moves no channel keeps the notes but sets the
    zone's ranges back to ±48 and ±2; an NRPN's data entry is not a bend range."""
    from hapticgraph.devices.midi import write_midi_file
    g = gestures()
    events = [(10, g.on(3, 60)), (20, g.bend(3, 4096))]
    events += [(30, m) for m in g.rpn(3, 0, 12, 50)]                     # ±12.5 semitones
    events += [(40, m) for m in [g.cc(3, 99, 0), g.cc(3, 98, 0), g.cc(3, 6, 1)]]   # an NRPN: ignored
    events += [(50, m) for m in g.mcm(0, 15)]
    write_midi_file(tmp_path / "r.mid", events, RATE)
    r = play(write_patch, tmp_path / "r.mid", "lower", seconds=0.002, voices=2)
    assert offset(r, 0, 20, 60) == near(24) and offset(r, 0, 30, 60) == near(6.25)
    assert offset(r, 0, 40, 60) == near(6.25)
    assert offset(r, 0, 50, 60) == near(24) and r["gate"][50:, 0].min() == 1.0


@pytest.mark.parametrize("first", ["note", "mcm"])
def test_a_note_on_a_channel_the_configuration_message_of_its_sample_moves_out_is_not_played(
        write_patch, tmp_path, first):
    """The RPN messages of a sample come first: an MCM shrinking the lower zone to 2 members at
    the sample of a note-on on channel 5 (index 4) leaves that note out, in either order (before,
    the note came in by the old zones and the allocator raised a TypeError on its channel)."""
    from hapticgraph.devices.midi import write_midi_file
    g = gestures()
    note, mcm = [g.on(4, 60)], list(g.mcm(0, 2))
    events = [(10, g.on(1, 64))] + [(20, m) for m in (note + mcm if first == "note" else mcm + note)]
    write_midi_file(tmp_path / "m.mid", events, RATE)
    r = play(write_patch, tmp_path / "m.mid", "lower", seconds=0.002, voices=2)
    assert r["gate"][15].sum() == 1.0 and r["gate"][25].sum() == 1.0    # channel 2's note only
    assert offset(r, int(np.argmax(r["gate"][25])), 25, 64) == near(0.0)
