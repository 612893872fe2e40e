"""MIDI in from a Standard MIDI File (`{driver: midi, file: ...}`): every event at its exact sample,
whatever the block size and the engine; midi_note's last-note priority, pitch bend, velocity,
pressure; midi_cc's range, curve, smoothing."""
import math

import mido
import numpy as np
import pytest
from hapticgraph.devices.midi import read_midi_file, write_midi_file

import hapticgraph

RATE = 48000
PATCH = """
hapticgraph: 1
rate: 48000
devices:
  song: {driver: midi, file: song.mid}
blocks:
  note: {type: midi_note, device: song, channel: CHANNEL, bend_range: 2.0}
  cc: {type: midi_cc, device: song, number: 74, min: 100.0, max: 1000.0, curve: exponential}
  slow: {type: midi_cc, device: song, number: 74, min: 0.0, max: 1.0, smooth: 0.001}
  out: {type: audio_out, channels: 1}
connect:
  - note.gate -> out.ch0
"""
PROBES = ["note.gate", "note.freq", "note.velocity", "note.pressure", "cc.out", "slow.out"]


def _song(path):
    """Two tracks, 480 ticks per beat, a tempo change in the middle: event times that fall
    between samples, so rounding the wrong way would show."""
    mid = mido.MidiFile(type=1, ticks_per_beat=480)
    meta = mido.MidiTrack([mido.MetaMessage("set_tempo", tempo=500000, time=0),
                           mido.MetaMessage("set_tempo", tempo=437000, time=200)])
    notes = mido.MidiTrack([
        mido.Message("note_on", note=60, velocity=100, time=7),
        mido.Message("note_on", note=64, velocity=50, time=31),        # a second key: it sounds
        mido.Message("note_off", note=64, time=45),                    # released: back to 60, legato
        mido.Message("pitchwheel", pitch=4096, time=13),
        mido.Message("aftertouch", value=127, time=5),
        mido.Message("control_change", control=74, value=127, time=3),
        mido.Message("note_off", note=60, time=150),                   # after the tempo change
        mido.Message("note_on", note=67, velocity=127, channel=3, time=10),
        mido.Message("note_off", note=67, channel=3, time=40),
    ])
    mid.tracks += [meta, notes]
    mid.save(path)


def _expected_samples(path):
    """Each message's time from mido's own clock (floats), to the first sample at or after it."""
    t, out = 0.0, []
    for msg in mido.MidiFile(path):
        t += msg.time
        if not msg.is_meta:
            out.append((math.ceil(t * RATE - 1e-6), msg))
    return out


@pytest.fixture
def song_patch(tmp_path):
    def make(channel=0):
        _song(tmp_path / "song.mid")
        (tmp_path / "p.yaml").write_text(PATCH.replace("CHANNEL", str(channel)))
        return hapticgraph.load(tmp_path / "p.yaml")
    return make


def test_reader_agrees_with_mido_clock(tmp_path):
    _song(tmp_path / "song.mid")
    mine = read_midi_file(tmp_path / "song.mid", RATE)
    theirs = _expected_samples(tmp_path / "song.mid")
    assert [s for s, _ in mine] == [s for s, _ in theirs]
    assert [m.type for _, m in mine] == [m.type for _, m in theirs]


@pytest.mark.parametrize("engine,chunk", [("compiled", 64), ("compiled", 1000), ("compiled", 1 << 14),
                                          ("python", 333)])
def test_notes_start_at_their_exact_sample(song_patch, tmp_path, engine, chunk):
    patch = song_patch()
    r = hapticgraph.render(patch, 0.6, probes=PROBES, engine=engine, chunk=chunk)
    at = {m.type + str(getattr(m, "note", "")) + str(getattr(m, "channel", "")): s
          for s, m in _expected_samples(tmp_path / "song.mid")}
    gate, freq = r.probes["note.gate"], r.probes["note.freq"]
    on = at["note_on600"]
    assert gate[on - 1] == 0.0 and gate[on] == 1.0 and freq[on - 1] == 440.0
    assert freq[on] == pytest.approx(440 * 2 ** ((60 - 69) / 12), rel=1e-12)
    second, back = at["note_on640"], at["note_off640"]
    assert freq[second - 1] == freq[on] and freq[second] == pytest.approx(440 * 2 ** ((64 - 69) / 12), rel=1e-12)
    assert r.probes["note.velocity"][second] == pytest.approx(50 / 127)
    assert freq[back] == freq[on] and gate[back] == 1.0          # last-note priority: back to the held key
    bend = at["pitchwheel0"]
    assert freq[bend] == pytest.approx(440 * 2 ** ((60 - 69 + 0.5 * 2.0) / 12), rel=1e-12)
    assert r.probes["note.pressure"][at["aftertouch0"] - 1] == 0.0
    assert r.probes["note.pressure"][at["aftertouch0"]] == 1.0
    release = at["note_off600"]
    assert gate[release - 1] == 1.0 and gate[release] == 0.0
    assert gate[on:release].min() == 1.0 and gate[:on].max() == 0.0
    other, off = at["note_on673"], at["note_off673"]      # omni: channel 4's note plays too
    assert gate[other - 1] == 0.0 and gate[other:off].min() == 1.0 and gate[off] == 0.0
    assert np.array_equal(r.audio[:, 0], gate)


def test_channel_filter(song_patch):
    r = hapticgraph.render(song_patch(channel=4), 0.6, probes=PROBES)
    gate = r.probes["note.gate"]
    assert gate.max() == 1.0
    assert r.probes["note.freq"][gate > 0] == pytest.approx(440 * 2 ** ((67 - 69) / 12))


def test_cc_range_curve_and_smoothing(song_patch, tmp_path):
    r = hapticgraph.render(song_patch(), 0.6, probes=PROBES, chunk=100)
    at = {m.type: s for s, m in _expected_samples(tmp_path / "song.mid") if m.type == "control_change"}
    i = at["control_change"]
    cc, slow = r.probes["cc.out"], r.probes["slow.out"]
    assert cc[0] == 100.0 and cc[i - 1] == 100.0 and cc[i] == pytest.approx(1000.0, rel=1e-12)
    # one pole, time constant 1 ms: after k samples 1 − exp(−k/(0.001·fs)) of the step (exact recursion)
    a = 1 - math.exp(-1 / (0.001 * RATE))
    k = np.arange(1, 200)
    np.testing.assert_allclose(slow[i - 1 + k], 1 - (1 - a) ** k, rtol=1e-12)


def test_take_file_one_tick_per_sample(tmp_path):
    events = [(0, mido.Message("note_on", note=1)), (12345, mido.Message("control_change", value=9)),
              (12346, mido.Message("note_off", note=1)), (480000, mido.Message("pitchwheel", pitch=-8192))]
    for rate in (44100, 48000, 96000):
        write_midi_file(tmp_path / "t.mid", events, rate)
        back = read_midi_file(tmp_path / "t.mid", rate)
        assert [s for s, _ in back] == [s for s, _ in events]
        assert [m.bytes() for _, m in back] == [m.bytes() for _, m in events]


def test_silent_device_holds_the_start_values(write_patch):
    patch = hapticgraph.load(write_patch(PATCH.replace("{driver: midi, file: song.mid}", "{driver: midi}")
                                         .replace("CHANNEL", "0")))
    r = hapticgraph.render(patch, 0.01, probes=PROBES)
    assert r.probes["note.gate"].max() == 0.0 and np.all(r.probes["note.freq"] == 440.0)
    assert np.all(r.probes["cc.out"] == 100.0)


@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_same_sample_events_in_either_order_and_notes_by_channel(tmp_path, chunk):
    """midi_note (newest note held): a note-off and a note-on of one key at one sample leave the
    new note sounding whatever their order; another channel's note-off leaves a note alone; a
    note struck and released at one sample sounds for that sample."""
    events = [(10, mido.Message("note_on", note=60, velocity=100)),
              (20, mido.Message("note_on", note=60, velocity=50)), (20, mido.Message("note_off", note=60)),
              (30, mido.Message("note_off", note=60, channel=5)),               # channel 6 holds no 60
              (40, mido.Message("note_off", note=60)), (40, mido.Message("note_on", note=60, velocity=70)),
              (50, mido.Message("note_off", note=60)),
              (60, mido.Message("note_on", note=62, velocity=127)), (60, mido.Message("note_off", note=62))]
    write_midi_file(tmp_path / "song.mid", events, RATE)
    (tmp_path / "p.yaml").write_text(PATCH.replace("CHANNEL", "0"))
    r = hapticgraph.render(hapticgraph.load(tmp_path / "p.yaml"), 0.002, probes=PROBES, chunk=chunk)
    gate, velocity = r.probes["note.gate"], r.probes["note.velocity"]
    assert gate[:10].max() == 0.0 and gate[10:50].min() == 1.0 and gate[50:60].max() == 0.0
    assert velocity[20] == pytest.approx(50 / 127) and velocity[40] == pytest.approx(70 / 127)
    assert gate[60] == 1.0 and gate[61:].max() == 0.0
    assert r.probes["note.freq"][60] == pytest.approx(440 * 2 ** ((62 - 69) / 12))


def test_a_device_that_never_stops_is_abandoned_with_one_line(song_patch, monkeypatch, capsys):
    """Session.stop gives each device STOP_SECONDS; past it the device is left behind, named."""
    import threading
    import time

    import hapticgraph.graph.engine as engine
    from hapticgraph.devices import open_drivers
    monkeypatch.setattr(engine, "STOP_SECONDS", 0.2)
    patch = song_patch()
    drivers = open_drivers(patch)
    release = threading.Event()
    monkeypatch.setattr(drivers["song"], "stop", lambda: release.wait(30))
    session = engine.Runner(patch, drivers=drivers, blocksize=64)
    session.process(64)
    began = time.monotonic()
    session.stop()
    took = time.monotonic() - began
    release.set()
    assert took < 5.0 and not session.started
    assert capsys.readouterr().err.splitlines() == ["hapticgraph: device 'song' did not close within 0.2 s: abandoned"]
