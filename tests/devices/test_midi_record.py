"""`play --record` captures live MIDI (notes and CCs sent from a python-rtmidi JACK port to the
patch's `{driver: midi, port: ..., api: jack}` device through a real `jackd -d dummy` server, while
playing out through the same server, in real time), monophonic and through a `voices:`
allocator: the take re-renders offline (`run --replay`) bit for bit."""
import subprocess
import sys
import time

import numpy as np
import pytest
from audio_env import hapticgraph, jack_or_skip
from hapticgraph.devices.record import Take
from scipy.io import wavfile

rtmidi = pytest.importorskip("rtmidi")

MONO = """
hapticgraph: 1
rate: 48000
devices:
  keys: {driver: midi, port: hg-rec-keys, api: jack}
blocks:
  note: {type: midi_note, device: keys}
  cc: {type: midi_cc, device: keys, number: 1, min: 0.0, max: 1.0}
  tone: {type: wavetable, shape: sine, frequency: 220.0, amplitude: 0.2}
  amp: {type: gain, gain: 0.0}
  level: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - note.freq -> tone.frequency
  - tone.out -> amp.in
  - note.gate -> amp.gain
  - amp.out -> level.in
  - cc.out -> level.gain
  - level.out -> out.ch0
map:
  - {param: tone.amplitude, cc: 74, min: 0.05, max: 0.5, curve: exponential}
"""

POLY = """
hapticgraph: 1
rate: 48000
devices:
  keys: {driver: midi, port: hg-rec-keys, api: jack}
blocks:
  cc: {type: midi_cc, device: keys, number: 1, min: 0.0, max: 1.0}
  mix: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - cc.out -> mix.gain
  - mix.out -> out.ch0
voices:
  count: 2
  blocks:
    note: {type: midi_note, device: keys}
    tone: {type: wavetable, shape: sine, frequency: 220.0, amplitude: 0.2}
    amp: {type: gain, gain: 0.0}
  connect:
    - note.freq -> tone.frequency
    - tone.out -> amp.in
    - note.gate -> amp.gain
    - amp.out -> mix.in
"""

KEYS = (60, 64, 67, 72)


@pytest.fixture
def keyboard(tmp_path, monkeypatch):
    """A JACK server of our own and a python-rtmidi JACK output port on it; (port, env of play)."""
    jack = jack_or_skip(tmp_path, rate=48000)
    monkeypatch.setenv("JACK_DEFAULT_SERVER", jack.name)
    monkeypatch.setenv("JACK_NO_START_SERVER", "1")
    out = rtmidi.MidiOut(rtmidi.API_UNIX_JACK, name="kbd")
    try:
        out.open_virtual_port("hg-rec-keys")
        yield out, jack.env
    finally:
        out.close_port()
        out.delete()
        jack.stop()


def _messages(k):
    """The k-th burst: a chord's keys pressed and released in turn, the mod wheel moving."""
    key = KEYS[k % len(KEYS)]
    other = KEYS[(k + 1) % len(KEYS)]
    return [[0x90, key, 40 + k % 80], [0x90, other, 100], [0xB0, 1, 1 + (7 * k) % 127], [0xB0, 74, (11 * k) % 128],
            [0x80, key, 0]] + ([[0x80, other, 0]] if k % 3 == 0 else [])


DEADLINE = 240.0     # seconds a 2-second play may take, start-up and compile included, on a loaded machine


def _play_and_send(path, take, out, env, command=None):
    proc = subprocess.Popen(command or [sys.executable, "-m", "hapticgraph", "play", path, "--seconds", "2",
                                        "--blocksize", "128", "--audio-device", "system", "--record", take],
                            env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + DEADLINE
    try:
        k = 0
        while proc.poll() is None:         # JACK paces play: keep sending until it has recorded and exited
            if time.monotonic() > deadline:
                proc.kill()
                _, err = proc.communicate(timeout=30)
                raise AssertionError(f"play did not exit within {DEADLINE:g} s: {err[-2000:]}")
            for message in _messages(k):
                out.send_message(message)
            k += 1
            time.sleep(0.005)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
        proc.wait(timeout=30)
    return proc.returncode, err


@pytest.mark.parametrize("text, notes", [(MONO, ["note"]), (POLY, ["v1_note", "v2_note"])], ids=["mono", "voices"])
def test_live_midi_take_rerenders_bit_for_bit(tmp_path, write_patch, keyboard, text, notes):
    out, env = keyboard
    path = write_patch(text)
    take = tmp_path / "take"
    code, err = _play_and_send(path, take, out, env)
    assert code == 0, err
    t = Take(f"{take}.hgrec")
    drivers = t.header["drivers"]
    assert drivers["cc"]["kind"] == "midi" and drivers["cc"]["model"] is None
    cc = t.inputs[:, drivers["cc"]["offset"]]
    assert len(np.unique(cc)) > 3                                  # the mod wheel reached the take
    if "map_tone_amplitude" in drivers:                            # a `map:` entry is a block like any other
        assert len(np.unique(t.inputs[:, drivers["map_tone_amplitude"]["offset"]])) > 3
    for name in notes:                                             # so did the notes, to every voice
        assert drivers[name]["kind"] == "midi"
        off = drivers[name]["offset"]
        gate, key = t.inputs[:, off], t.inputs[:, off + 1]
        assert {0.0, 1.0} <= set(np.unique(gate)) and len(set(np.unique(key)) & set(KEYS)) >= 2
    _, heard = wavfile.read(f"{take}.wav")
    assert np.abs(heard).max() > 0.01
    r = hapticgraph(["run", path, "--replay", f"{take}.hgrec", "--out", tmp_path / "run.wav", "--quiet"], env)
    assert r.returncode == 0, r.stderr
    _, replayed = wavfile.read(tmp_path / "run.wav")
    assert replayed.shape == heard.shape
    assert np.array_equal(replayed.view(np.uint32), heard.view(np.uint32))
    if text is MONO:                                               # played again from the take, recorded again
        r = hapticgraph(["play", path, "--replay", f"{take}.hgrec", "--blocksize", "128", "--audio-device",
                         "system", "--record", tmp_path / "again"], env)
        assert r.returncode == 0, r.stderr
        t2 = Take(tmp_path / "again.hgrec")
        assert {d["kind"] for d in t2.header["drivers"].values()} == {"midi"}
        assert np.array_equal(t2.data, t.data)
        _, heard2 = wavfile.read(tmp_path / "again.wav")
        assert np.array_equal(heard2.view(np.uint32), heard.view(np.uint32))


# play whose MIDI port never finishes closing (PortReader.close blocks for good): the device is
# abandoned after its deadline with one line naming it, play exits 0, the take and the WAV whole
STUCK = """
import sys, threading
import hapticgraph.graph.engine as engine
from hapticgraph.cli import main
from hapticgraph.devices.midi import PortReader
engine.STOP_SECONDS = 1.0
PortReader.close = lambda self: threading.Event().wait()
sys.exit(main(sys.argv[1:]))
"""


def test_a_device_that_never_closes_is_abandoned_and_the_take_kept(tmp_path, write_patch, keyboard):
    out, env = keyboard
    path = write_patch(MONO)
    take = tmp_path / "take"
    began = time.monotonic()
    code, err = _play_and_send(path, take, out, env, [sys.executable, "-c", STUCK, "play", str(path), "--seconds",
                                                      "1", "--blocksize", "128", "--audio-device", "system",
                                                      "--record", str(take)])
    assert code == 0, err
    lines = [line for line in err.splitlines() if "abandoned" in line]
    assert lines == ["hapticgraph: device 'keys' did not close within 1 s: abandoned"], err
    assert time.monotonic() - began < DEADLINE
    t = Take(f"{take}.hgrec")
    rate, heard = wavfile.read(f"{take}.wav")
    assert rate == 48000 and len(heard) >= 48000 and t.frames >= 48000
    assert len(np.unique(t.inputs[:, t.header["drivers"]["cc"]["offset"]])) > 3
