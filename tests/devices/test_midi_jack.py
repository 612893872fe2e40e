"""Live MIDI through a real JACK server (`jackd -d dummy`, its own server name): a python-rtmidi
output port plays the patch's `{driver: midi, port: ...}` device; `hapticgraph devices` lists it."""
import os
import subprocess
import sys
import threading
import time
import uuid

import numpy as np
import pytest
import rtmidi
from hapticgraph.devices import open_drivers
from hapticgraph.devices.midi import list_ports, write_midi_file
from hapticgraph.graph.engine import Runner

import hapticgraph

PATCH = """
hapticgraph: 1
rate: 48000
devices:
  keys: {driver: midi, port: PORT, api: jack}
blocks:
  note: {type: midi_note, device: keys}
  cc: {type: midi_cc, device: keys, number: 1, min: 0.0, max: 10.0}
  out: {type: audio_out, channels: 1}
connect:
  - note.gate -> out.ch0
"""


def _client(name, deadline):
    """A JACK MIDI output client, retried until `deadline` (a loaded server may refuse one
    moment and accept the next); None if it never did."""
    while time.monotonic() < deadline:
        try:
            return rtmidi.MidiOut(rtmidi.API_UNIX_JACK, name=name)
        except Exception:  # noqa: BLE001 - not up yet
            time.sleep(0.1)
    return None


def _wait_for_server(deadline):
    probe = _client("probe", deadline)
    if probe is not None:
        probe.delete()
    return probe is not None


@pytest.fixture
def jack(monkeypatch):
    """A JACK server of our own (dummy backend, 48 kHz, 64-frame periods), by a unique name."""
    name = f"hgtest-{uuid.uuid4().hex[:8]}"
    monkeypatch.setenv("JACK_DEFAULT_SERVER", name)
    monkeypatch.setenv("JACK_NO_START_SERVER", "1")
    proc = subprocess.Popen(["jackd", "-n", name, "-d", "dummy", "-r", "48000", "-p", "64"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert _wait_for_server(time.monotonic() + 20), "jackd did not start"
        yield name
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:      # a loaded server slow to go: killed, still bounded
            proc.kill()
            proc.wait(timeout=10)


@pytest.fixture
def keyboard(jack):
    out = _client("kbd", time.monotonic() + 20)
    assert out is not None, "no JACK MIDI client could be made in 20 s"
    out.open_virtual_port("hg-keys")
    yield out
    out.close_port()
    out.delete()


def _run_until(session, keyboard, blocks, send, want, every=0):
    """Process blocks at about real time, sending `send` at the third block (with `every`, one
    message each `every` blocks from there); stop when `want(rec)` holds."""
    n = session.blocksize
    seen = []
    for k in range(blocks):
        for j, message in enumerate(send):
            if k == 2 + every * j:
                keyboard.send_message(message)
        time.sleep(n / session.rate)
        rec = session.process(n).copy()
        seen.append(rec)
        if want(np.concatenate(seen)):
            break
    return np.concatenate(seen)


def test_port_listed_and_played(keyboard, write_patch):
    assert any("hg-keys" in p for _, p in list_ports("jack"))
    patch = hapticgraph.load(write_patch(PATCH.replace("PORT", "hg-keys")))
    session = Runner(patch, probes=["note.freq", "note.velocity", "cc.out"], drivers=open_drivers(patch),
                      blocksize=256)
    try:
        rec = _run_until(session, keyboard, 400, [[0x90, 72, 127], [0xE0, 0, 0x60], [0xB0, 1, 127]],
                         lambda r: r[:, 3].max() == 10.0 and r[:, 1].max() > 1000)
    finally:
        session.stop()
    gate, freq, vel, cc = rec[:, :4].T
    first = int(np.argmax(gate > 0))
    assert gate[first] == 1.0 and gate[:first].max() == 0.0
    bent = 440 * 2 ** ((72 - 69 + 2 * (0x60 * 128 - 8192) / 8192) / 12)
    # the wheel sent right after the key may arrive in the same JACK cycle: at the same sample
    assert freq[first] in (pytest.approx(440 * 2 ** ((72 - 69) / 12)), pytest.approx(bent))
    assert vel[first] == 1.0
    assert freq.max() == pytest.approx(bent)
    assert cc[0] == 0.0 and cc.max() == 10.0


def test_missing_port_is_one_clear_error(jack, write_patch):
    patch = hapticgraph.load(write_patch(PATCH.replace("PORT", "no-such-port")))
    drivers = open_drivers(patch)
    with pytest.raises(Exception, match="no MIDI input port matching 'no-such-port'"):
        Runner(patch, drivers=drivers, blocksize=64).start()


def test_devices_lists_midi_ports(keyboard):
    proc = subprocess.run([sys.executable, "-m", "hapticgraph", "devices"], capture_output=True, text=True, check=False,
                          env=dict(os.environ), timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "MIDI input ports" in proc.stdout and "hg-keys" in proc.stdout


POLY = """
hapticgraph: 1
rate: 48000
devices:
  keys: {driver: midi, port: hg-keys, api: jack}
blocks:
  out: {type: audio_out, channels: 1}
voices:
  count: 2
  blocks:
    note: {type: midi_note, device: keys}
  connect:
    - note.gate -> out.ch0
"""


def test_live_notes_are_allocated_to_voices_as_from_a_file(keyboard, write_patch, tmp_path):
    """Three keys through the live path into two voices: the third steals the first voice, its
    gate dipping the sample before. The events as the port delivered them, written to a MIDI file
    and rendered from it, give the same voices sample for sample."""
    patch = hapticgraph.load(write_patch(POLY))
    probes = ["v1_note.gate", "v1_note.freq", "v2_note.gate", "v2_note.freq"]
    drivers = open_drivers(patch)
    drivers["keys"].log = []
    session = Runner(patch, probes=probes, drivers=drivers, blocksize=256)
    f = [440 * 2 ** ((key - 69) / 12) for key in (60, 64, 67)]
    try:
        rec = _run_until(session, keyboard, 400, [[0x90, 60, 100], [0x90, 64, 100], [0x90, 67, 100]],
                         lambda r: np.isclose(r[:, 2], f[2]).any() and r[-1, 1] == 1.0, every=2)
    finally:
        session.stop()
    g1, f1, g2, f2 = rec[:, 1:5].T
    first, second = int(np.argmax(g1 > 0)), int(np.argmax(g2 > 0))
    assert first < second and f1[first] == pytest.approx(f[0]) and f2[second] == pytest.approx(f[1])
    stolen = int(np.argmax(np.isclose(f1, f[2])))
    assert g1[stolen - 1] == 0.0 and g1[stolen] == 1.0 and g1[first:stolen - 1].min() == 1.0
    assert g2[second:].min() == 1.0 and np.allclose(f2[second:], f[1])
    write_midi_file(tmp_path / "live.mid", drivers["keys"].log, 48000)
    offline = hapticgraph.load(write_patch(POLY.replace("{driver: midi, port: hg-keys, api: jack}",
                                                        "{driver: midi, file: live.mid}"), "file.yaml"))
    for chunk in (1, 100, 4096):
        r = hapticgraph.render(offline, len(rec) / 48000, probes=probes, chunk=chunk)
        assert np.array_equal(np.stack([r.probes[p] for p in probes], axis=1), rec[:, 1:5]), chunk


# a live port opened and closed again and again while a keyboard floods it: the close must never
# wait for the MIDI system's thread while that thread waits for Python (issue 21: a callback on
# JACK's thread needed the GIL that close_port held); run apart, so a deadlock cannot hang pytest
CYCLES = """
import sys, time
from hapticgraph.devices.midi import MidiHub
hub = MidiHub("keys", {"port": "hg-keys", "api": "jack"})
heard = 0
for k in range(int(sys.argv[1])):
    hub.start(48000)
    time.sleep(0.02)
    heard += len(hub.events(0, 64))
    hub.stop()
print(k + 1, heard)
"""


def test_closing_a_port_while_it_is_played_is_bounded(keyboard):
    stop = threading.Event()

    def flood():
        for k in range(200_000):               # bounded in count, and by the event
            if stop.is_set():
                return
            keyboard.send_message([0x90 if k % 2 == 0 else 0x80, 60 + k % 12, 100])
            time.sleep(0.0002)
    sender = threading.Thread(target=flood, daemon=True)
    sender.start()
    try:
        proc = subprocess.run([sys.executable, "-c", CYCLES, "30"], capture_output=True, text=True, timeout=240,
                              check=False)
    finally:
        stop.set()
        sender.join(10)
    assert proc.returncode == 0, proc.stderr
    cycles, heard = map(int, proc.stdout.split())
    assert cycles == 30 and heard > 0
