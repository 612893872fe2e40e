"""`play --record` captures controller input (here OSC over loopback UDP, received live while
playing in real time through a `jackd -d dummy` server): the take re-renders offline (`run
--replay`) bit for bit."""
import os
import socket
import subprocess
import sys
import time

import numpy as np
from audio_env import hapticgraph, jack_or_skip
from hapticgraph.devices.record import Take
from osc_env import osc_listener
from pythonosc.udp_client import SimpleUDPClient
from scipy.io import wavfile

PATCH = """
hapticgraph: 1
rate: 44100
devices:
  ctl: {driver: osc, port: PORT}
blocks:
  tone: {type: wavetable, shape: sine, frequency: 220.0, amplitude: 0.1}
  level: {type: osc_in, device: ctl, address: /level}
  amp: {type: gain, gain: 0.0}
  out: {type: audio_out, channels: 1}
connect:
  - tone.out -> amp.in
  - amp.out -> out.ch0
  - level.out -> amp.gain
map:
  - {param: tone.frequency, osc: /pitch, min: 110.0, max: 880.0, curve: exponential}
"""


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_osc_take_rerenders_bit_for_bit(tmp_path, write_patch):
    jack = jack_or_skip(tmp_path)
    env = jack.env
    port = _free_port()
    path = write_patch(PATCH.replace("PORT", str(port)))
    take = tmp_path / "take"
    proc = subprocess.Popen([sys.executable, "-m", "hapticgraph", "play", path, "--seconds", "2",
                             "--blocksize", "256",
                             "--audio-device", "system", "--record", take], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    client = SimpleUDPClient("127.0.0.1", port)
    try:
        k = 0
        deadline = time.monotonic() + 120   # play --seconds 2 under JACK: far past its end is a hang
        while proc.poll() is None and time.monotonic() < deadline:   # JACK paces play: send until it exits
            client.send_message("/level", 1.0 + k % 3)
            client.send_message("/pitch", (k % 5) / 4)
            k += 1
            time.sleep(0.001)
        _, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
        jack.stop()
    assert proc.returncode == 0, err
    t = Take(f"{take}.hgrec")
    assert t.header["drivers"]["level"]["kind"] == "osc"             # the device's driver kind, not code
    level = t.inputs[:, t.header["drivers"]["level"]["offset"]]
    assert set(np.unique(level)) >= {1.0, 2.0, 3.0}    # the messages reached the take (0 before the first: timing)
    _, heard = wavfile.read(f"{take}.wav")
    again = tmp_path / "again.wav"
    r = hapticgraph(["run", path, "--replay", f"{take}.hgrec", "--out", again, "--quiet"], env)
    assert r.returncode == 0, r.stderr
    _, replayed = wavfile.read(again)
    assert np.abs(heard).max() > 0.05
    assert np.array_equal(replayed.view(np.uint32), heard.view(np.uint32))


PROBED = """
hapticgraph: 1
rate: 44100
blocks:
  tone: {type: wavetable, shape: sine, frequency: 3.0, amplitude: 0.5}
  out: {type: audio_out, channels: 1}
connect:
  - tone.out -> out.ch0
"""


def test_play_sends_probes_over_osc(tmp_path, write_patch):
    """`play --probe P --osc-out HOST:PORT --osc-rate R`: /BLOCK/PORT carries the probe's value at
    every R-th of a second of patch time (each value as the offline render has it, in OSC's
    32-bit float), sent while playing in real time."""
    jack = jack_or_skip(tmp_path)
    path = write_patch(PROBED)
    with osc_listener("/tone/out") as osc:
        try:
            r = subprocess.run([sys.executable, "-m", "hapticgraph", "play", path, "--seconds", "1",
                                "--audio-device", "system", "--probe", "tone.out",
                                "--osc-out", f"127.0.0.1:{osc.port}", "--osc-rate", "50"],
                               env=jack.env, text=True, capture_output=True, timeout=120)
            osc.wait_for(50, timeout=5.0)
        finally:
            jack.stop()
    got = osc.got["/tone/out"]
    assert r.returncode == 0, r.stderr
    assert len(got) == 50                                  # 1 s of patch time at 50 a second
    offline = hapticgraph(["run", path, "--seconds", "1", "--probe", "tone.out",
                           "--out", tmp_path / "x.wav", "--quiet"], dict(os.environ))
    assert offline.returncode == 0, offline.stderr
    probe = np.load(tmp_path / "x.npz")["tone.out"]
    assert np.array_equal(np.float32(got), probe[::882].astype(np.float32))   # 44100 / 50 = 882


def test_play_osc_out_options_are_checked(tmp_path, write_patch):
    path = write_patch(PROBED)
    for extra, message in ((["--probe", "tone.out"], "give --osc-out"),
                           (["--osc-out", "9001"], "name at least one with --probe"),
                           (["--osc-out", "host:port", "--probe", "tone.out"], "expected HOST:PORT"),
                           (["--osc-out", "9001", "--probe", "tone.out", "--osc-rate", "0"], "--osc-rate 0")):
        r = hapticgraph(["play", path, "--seconds", "0.1", *extra], dict(os.environ))
        assert r.returncode == 2, (extra, r.stderr)
        assert message in r.stderr and "Traceback" not in r.stderr
