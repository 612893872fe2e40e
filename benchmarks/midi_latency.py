"""Latency from a MIDI event's timestamp to its first effect in the audio, under a real JACK server.

    python benchmarks/midi_latency.py [--notes 50] [--period 64] [--rate 48000] [--voices N]

Starts its own `jackd -d dummy` (a unique server name), plays a patch whose sound is midi_note's
gate through PortAudio's JACK host API (the audio callback runs hapticgraph's Session, as `play`
does), and sends note-on / note-off pairs from a python-rtmidi JACK output port at random moments.
For each note-on it records PortAudio's stream clock just before the send (the event's
timestamp), finds the first sample of the callback's output where the gate is 1, and takes that
sample's DAC time (outputBufferDacTime + index / rate) from the same clock. It prints the
distribution of (DAC time − send time) — median, 95th percentile, max — and the part of it spent
before the kernel's output block (send → the block's DAC start), so the output buffering is
visible separately. With `--voices N` the gate is the sum of a `voices:` template's N allocated
midi_note gates (each note-on a different key, so the allocator rotates through the voices).
"""
import argparse
import os
import random
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid

import numpy as np

PATCH = """
hapticgraph: 1
rate: {rate}
devices:
  keys: {{driver: midi, port: latency-keys, api: jack}}
blocks:
  note: {{type: midi_note, device: keys}}
  out: {{type: audio_out, channels: 1}}
connect:
  - note.gate -> out.ch0
"""
POLY = """
hapticgraph: 1
rate: {rate}
devices:
  keys: {{driver: midi, port: latency-keys, api: jack}}
blocks:
  out: {{type: audio_out, channels: 1}}
voices:
  count: {voices}
  blocks:
    note: {{type: midi_note, device: keys}}
  connect:
    - note.gate -> out.ch0
"""


def start_jack(rate, period):
    name = f"hglat-{uuid.uuid4().hex[:8]}"
    os.environ["JACK_DEFAULT_SERVER"] = name
    os.environ["JACK_NO_START_SERVER"] = "1"
    proc = subprocess.Popen(["jackd", "-n", name, "-d", "dummy", "-r", str(rate), "-p", str(period)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    import rtmidi
    for _ in range(200):
        try:
            rtmidi.MidiOut(rtmidi.API_UNIX_JACK, name="probe").delete()
            return proc
        except Exception:  # noqa: BLE001 - not up yet
            time.sleep(0.1)
    proc.terminate()
    raise SystemExit("jackd did not start")


def measure(notes, rate, period, voices=0):
    import rtmidi
    import sounddevice as sd
    from hapticgraph.devices import open_drivers
    from hapticgraph.graph.engine import Runner

    import hapticgraph

    keys = rtmidi.MidiOut(rtmidi.API_UNIX_JACK, name="latency")
    keys.open_virtual_port("latency-keys")
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "latency.yaml")
        with open(path, "w") as f:
            f.write(POLY.format(rate=rate, voices=voices) if voices else PATCH.format(rate=rate))
        patch = hapticgraph.load(path)
        session = Runner(patch, drivers=open_drivers(patch), blocksize=4096)
        session.start()
    hits, lock, state = [], threading.Lock(), {"pending": None}

    def callback(outdata, frames, when, status):
        rec = session.process(frames)
        outdata[:, 0] = rec[:, 0]
        with lock:
            pending = state["pending"]
            if pending is not None and rec[:, 0].max() > 0.5:
                i = int(np.argmax(rec[:, 0] > 0.5))
                hits.append((pending, when.outputBufferDacTime + i / rate, when.outputBufferDacTime))
                state["pending"] = None

    hostapi = next(k for k, h in enumerate(sd.query_hostapis()) if "JACK" in h["name"])
    device = sd.query_hostapis(hostapi)["default_output_device"]
    with sd.OutputStream(samplerate=rate, blocksize=period, channels=1, device=device, callback=callback,
                         latency="low") as stream:
        time.sleep(0.5)
        for k in range(notes):
            key = 48 + k % 24
            time.sleep(random.uniform(0.02, 0.06))
            with lock:
                state["pending"] = stream.time
            keys.send_message([0x90, key, 100])
            time.sleep(random.uniform(0.02, 0.04))
            keys.send_message([0x80, key, 0])
        time.sleep(0.1)
        reported = stream.latency
    session.stop()
    keys.close_port()
    sd._terminate()            # let go of the JACK server before it is stopped
    return hits, reported


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--notes", type=int, default=50)
    parser.add_argument("--period", type=int, default=64)
    parser.add_argument("--rate", type=int, default=48000)
    parser.add_argument("--voices", type=int, default=0, help="a voices: template of N allocated midi_note gates")
    args = parser.parse_args()
    jackd = start_jack(args.rate, args.period)
    try:
        hits, reported = measure(args.notes, args.rate, args.period, args.voices)
    finally:
        jackd.terminate()
        jackd.wait(timeout=10)
    total = [1e3 * (dac - sent) for sent, dac, _ in hits]
    before = [1e3 * (start - sent) for sent, _, start in hits]
    print(f"JACK dummy backend, {args.rate} Hz, {args.period}-frame periods (one period = "
          f"{1e3 * args.period / args.rate:.2f} ms); PortAudio output latency reported {1e3 * reported:.2f} ms")
    print(f"{len(hits)} of {args.notes} note-ons heard" + (f" ({args.voices} voices)" if args.voices else ""))
    for label, xs in (("send -> first audio sample at the DAC", total),
                      ("send -> start of the output block at the DAC", before)):
        if xs:
            q = np.percentile(xs, [5, 50, 95])
            print(f"{label}: median {q[1]:.2f} ms, p95 {q[2]:.2f} ms, max {max(xs):.2f} ms "
                  f"(p5 {q[0]:.2f}, min {min(xs):.2f}, mean {statistics.mean(xs):.2f})")
    return 0 if hits else 1


if __name__ == "__main__":
    sys.exit(main())
