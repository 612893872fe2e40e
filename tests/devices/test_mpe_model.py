"""Random MPE performances against an independent model of the MPE specification (v1.0).

A performance on the lower zone: notes on member channels, each set up before its note-on
(bend, slide, pressure on its channel), then bent, pressed and slid while held; the master
channel's bend, pressure and slide; RPN 0 on the master channel and on member channels; now and
then a note on the master channel. The model follows the specification, not hapticgraph's code: a
member-channel note sounds key + bend·(member range) + master bend·(master range); its pressure and
slide are the last value sent on its channel or on the master channel since its note-on (its
channel's value at the note-on); a master-channel note sounds key + master bend·(master range) and
takes key pressure. At every event's sample, and at the sample before the next one, each held
note is sounded by a voice of its own with those values, and no other voice's gate is up."""
import math

import mido
import numpy as np
import pytest

import hapticgraph
from hapticgraph.devices.midi import write_midi_file

RATE = 48000
S = 40                          # samples between two events
VOICES = 16
MASTER = 0


def performance(seed, steps=160):
    """[(sample, message)] and, per event, the model's held notes {note: (key, offset, pressure, slide)}."""
    rng = np.random.default_rng(seed)
    members = int(rng.integers(3, 16))
    events, states = [], []
    bend, pressure, slide = [0.0] * 16, [0.0] * 16, [64 / 127] * 16
    member_range, master_range = 48.0, 2.0
    held = {}                                   # (channel, key) -> [pressure, slide] of the note
    t = 1

    def emit(message):
        nonlocal t
        events.append((t * S, message))
        apply(message)
        states.append((t * S, snapshot()))
        t += 1

    def apply(m):
        nonlocal member_range, master_range
        c = m.channel
        if m.type == "pitchwheel":
            bend[c] = m.pitch / 8192
        elif m.type == "aftertouch":
            pressure[c] = m.value / 127
            for note, values in held.items():
                if c == MASTER or note[0] == c:
                    values[0] = pressure[c]
        elif m.type == "polytouch" and (c, m.note) in held:
            held[(c, m.note)][0] = m.value / 127
        elif m.type == "control_change" and m.control == 74:
            slide[c] = m.value / 127
            for note, values in held.items():
                if c == MASTER or note[0] == c:
                    values[1] = slide[c]
        elif m.type == "control_change" and m.control == 6:      # RPN 0 (the only RPN sent)
            if c == MASTER:
                master_range = float(m.value)
            else:
                member_range = float(m.value)
        elif m.type == "note_on":
            held[(c, m.note)] = [pressure[c], slide[c]] if c != MASTER else [pressure[c], slide[c]]
        elif m.type == "note_off":
            del held[(c, m.note)]
            if c != MASTER:             # the channel's next note starts from the middle
                bend[c], pressure[c], slide[c] = 0.0, 0.0, 64 / 127

    def snapshot():
        out = {}
        for (c, key), (p, s) in held.items():
            own = 0.0 if c == MASTER else bend[c] * member_range
            out[(c, key)] = (key, own + bend[MASTER] * master_range, p, s)
        return out

    if rng.random() < 0.7:
        for m in [mido.Message("control_change", channel=MASTER, control=101, value=0),
                  mido.Message("control_change", channel=MASTER, control=100, value=6),
                  mido.Message("control_change", channel=MASTER, control=6, value=members)]:
            events.append((0, m))
    else:
        members = 15
    keys = list(range(36, 96))
    for _ in range(steps):
        channels = [c for c in range(1, members + 1) if not any(n[0] == c for n in held)]
        choice = rng.integers(0, 9)
        if choice <= 1 and channels and len(held) < 8:
            c = channels[0] if rng.random() < 0.8 else int(rng.choice(channels))
            if rng.random() < 0.1 and not any(n[0] == MASTER for n in held):
                c = MASTER
            taken = {k for _, k in held}
            key = int(rng.choice([k for k in keys if k not in taken]))
            if c != MASTER:
                emit(mido.Message("pitchwheel", channel=c, pitch=int(rng.integers(-8192, 8192))))
                emit(mido.Message("control_change", channel=c, control=74, value=int(rng.integers(0, 128))))
                emit(mido.Message("aftertouch", channel=c, value=int(rng.integers(0, 128))))
            emit(mido.Message("note_on", channel=c, note=key, velocity=int(rng.integers(1, 128))))
        elif choice == 2 and held:
            c, key = list(held)[int(rng.integers(0, len(held)))]
            emit(mido.Message("note_off", channel=c, note=key))
        elif choice <= 5 and held:
            c, key = list(held)[int(rng.integers(0, len(held)))]
            if c == MASTER:
                emit(mido.Message("polytouch", channel=c, note=key, value=int(rng.integers(0, 128))))
                continue
            kind = rng.integers(0, 3)
            emit(mido.Message("pitchwheel", channel=c, pitch=int(rng.integers(-8192, 8192))) if kind == 0 else
                 mido.Message("aftertouch", channel=c, value=int(rng.integers(0, 128))) if kind == 1 else
                 mido.Message("control_change", channel=c, control=74, value=int(rng.integers(0, 128))))
        elif choice <= 7:
            kind = rng.integers(0, 4)
            emit(mido.Message("pitchwheel", channel=MASTER, pitch=int(rng.integers(-8192, 8192))) if kind <= 1 else
                 mido.Message("aftertouch", channel=MASTER, value=int(rng.integers(0, 128))) if kind == 2 else
                 mido.Message("control_change", channel=MASTER, control=74, value=int(rng.integers(0, 128))))
        else:
            c = MASTER if rng.random() < 0.5 else int(rng.integers(1, members + 1))
            semitones = int(rng.integers(1, 25) if c == MASTER else rng.integers(12, 97))
            for control, value in ((101, 0), (100, 0)):
                events.append((t * S, mido.Message("control_change", channel=c, control=control, value=value)))
            emit(mido.Message("control_change", channel=c, control=6, value=semitones))
    return events, states, t * S


@pytest.mark.parametrize("seed", range(6))
def test_random_performances_follow_the_model(write_patch, tmp_path, seed):
    events, states, length = performance(seed)
    write_midi_file(tmp_path / "take.mid", events, RATE)
    path = write_patch(f"""
        hapticgraph: 1
        rate: {RATE}
        devices:
          keys: {{driver: midi, file: take.mid}}
        blocks:
          out: {{type: audio_out, channels: 1}}
        voices:
          count: {VOICES}
          blocks:
            note: {{type: midi_note, device: keys, mpe: lower}}
          connect:
            - note.gate -> out.ch0
        """)
    ports = ("gate", "freq", "pressure", "slide")
    probes = [f"v{k}_note.{p}" for p in ports for k in range(1, VOICES + 1)]
    r = hapticgraph.render(hapticgraph.load(path), length / RATE, probes=probes, chunk=256)
    got = {p: np.stack([r.probes[f"v{k}_note.{p}"] for k in range(1, VOICES + 1)], axis=1) for p in ports}
    checked = 0
    for at, notes in states:
        for sample in (at, at + S - 1):
            gates = got["gate"][sample]
            assert int(gates.sum()) == len(notes), (sample, notes)
            free = set(np.flatnonzero(gates))
            for note, (key, semis, pressure, slide) in notes.items():
                match = [v for v in free
                         if abs(12 * math.log2(got["freq"][sample, v] / 440) + 69 - key - semis) < 1e-9
                         and got["pressure"][sample, v] == pressure and got["slide"][sample, v] == slide]
                assert match, (seed, sample, note, (key, semis, pressure, slide))
                free.discard(match[0])
                checked += 1
    assert checked > 200


@pytest.mark.parametrize("seed", [7, 8])
def test_live_mpe_gives_the_columns_a_file_of_it_gives(seed):
    """A random performance posted to a live hub in bursts (its clock faked), then the events it
    placed, as a file: the same MPE voices, sample for sample, in any block size."""
    from hapticgraph.devices.events import Hub
    from hapticgraph.devices.mpe import Zones
    from hapticgraph.devices.voices import DETUNE, Allocator
    messages = [m for _, m in performance(seed)[0]]
    rng, n = np.random.default_rng(seed), 64
    live, now = Hub("keys"), [0.0]
    live.clock = lambda: now[0]
    live.start(RATE)
    live.log = []
    alloc, blocks, t0 = Allocator(live, None, 8, Zones("lower")), [], 0
    while messages or t0 < 64 * n:
        stamps = np.sort(rng.uniform(now[0], now[0] + n / RATE, int(rng.integers(0, 6))))
        for stamp in stamps:
            for _ in range(int(rng.integers(1, 4))):
                if messages:
                    live.post(messages.pop(0), float(stamp))
        now[0] += n / RATE
        blocks.append(alloc.block(t0, n).transpose(1, 0, 2).copy())
        t0 += n
    played = np.concatenate(blocks)
    assert played[:, :, DETUNE].std() > 0 and len({s for s, _ in live.log}) < len(live.log)
    for block in (1, 64, 100):
        from_file = Allocator(Hub("song", timed=sorted(live.log, key=lambda e: e[0])), None, 8, Zones("lower"))
        from_file.hub.start(RATE)
        cols = np.concatenate([from_file.block(s, min(block, len(played) - s)).transpose(1, 0, 2).copy()
                               for s in range(0, len(played), block)])
        np.testing.assert_array_equal(cols, played)
