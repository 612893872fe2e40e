"""NAME_midi: the exported C's MIDI driver (hapticgraph.devices.midi_c) against the Python run's
(hapticgraph.devices.midi, .voices, .mpe). A patch whose audio channels are the outputs of every
kind of MIDI block — midi_note following the newest key (every channel, and channel 3), midi_cc,
and the three voices of a group (no MPE, and each MPE mode) — plays fuzzed event streams: collisions
at one sample (a note-off and a note-on, a restrike, all-notes-off, an MPE Configuration Message
among notes), steals, bends, pressures, slides, RPN and NRPN selections, events at chunk and call
boundaries. The C, given each call's events and those of the sample after it, gives the bits of
`hapticgraph render` of the same events written as a MIDI file, at two block sizes of the Python run."""
import re
import subprocess

import mido
import numpy as np
import pytest

import hapticgraph
from hapticgraph.devices.midi import read_midi_file, write_midi_file
from hapticgraph.export.compiler import build, compiler
from hapticgraph.graph.patch import load
from project_env import ROOT

RATE = 48000
SAMPLES = 4800
VOICES = 3
OUTPUTS = ("gate", "freq", "velocity", "pressure", "slide")


def patch_text(mpe):
    notes = {"mono": "{type: midi_note, device: keys, bend_range: 7.0}",
             "three": "{type: midi_note, device: keys, channel: 3}"}
    for k in range(1, VOICES + 1):
        notes[f"v{k}"] = f"{{type: midi_note, device: keys, voice: {k}, voices: {VOICES}, mpe: {mpe}}}"
    blocks = [f"  {name}: {spec}" for name, spec in notes.items()]
    blocks += ["  knob: {type: midi_cc, device: keys, number: 1, min: -1.0, max: 3.0}",
               "  bright: {type: midi_cc, device: keys, number: 74, channel: 2}"]
    wires = [f"{name}.{port}" for name in notes for port in OUTPUTS] + ["knob.out", "bright.out"]
    blocks.append(f"  out: {{type: audio_out, channels: {len(wires)}}}")
    connect = [f"  - {w} -> out.ch{k}" for k, w in enumerate(wires)]
    return "\n".join(["hapticgraph: 1", f"rate: {RATE}", "devices:", "  keys: {driver: midi, file: take.mid}",
                      "blocks:", *blocks, "connect:", *connect, ""])


def fuzzed(seed):
    """About 450 events over 0.1 s on 70 samples (many collide), some on the C's 256-sample chunk
    boundaries and on the driver's 1000-sample calls, six bend ranges set with their cents and
    followed by bends, as (sample, message) in order (sorted stably: a sample keeps its order)."""
    rng = np.random.default_rng(seed)
    samples = np.unique(np.concatenate([rng.integers(0, SAMPLES - 2, 60), [255, 256, 999, 1000, 1001, 2047, 2048]]))
    channels, keys = [0, 1, 2, 14, 15], [60, 61, 62, 64]

    def message():
        ch, key = int(rng.choice(channels)), int(rng.choice(keys))
        kind = rng.choice(["on", "on", "on", "off", "off", "bend", "touch", "poly", "cc", "rpn", "program"])
        if kind == "on":
            return mido.Message("note_on", channel=ch, note=key, velocity=int(rng.choice([0, 1, 64, 127, 100])))
        if kind == "off":
            return mido.Message("note_off", channel=ch, note=key, velocity=int(rng.integers(0, 128)))
        if kind == "bend":
            return mido.Message("pitchwheel", channel=ch, pitch=int(rng.integers(-8192, 8192)))
        if kind == "touch":
            return mido.Message("aftertouch", channel=ch, value=int(rng.integers(0, 128)))
        if kind == "poly":
            return mido.Message("polytouch", channel=ch, note=key, value=int(rng.integers(0, 128)))
        if kind == "program":
            return mido.Message("program_change", channel=ch, program=int(rng.integers(0, 128)))
        if kind == "cc":
            number = int(rng.choice([1, 74, 74, 64, 120, 123]))
            return mido.Message("control_change", channel=ch, control=number, value=int(rng.integers(0, 128)))
        number = int(rng.choice([101, 100, 6, 6, 38, 99, 98]))
        value = {101: 0, 100: int(rng.choice([0, 6, 6, 1])), 6: int(rng.integers(0, 16)),
                 38: int(rng.integers(0, 100))}.get(number, 0)
        return mido.Message("control_change", channel=int(rng.choice([0, 15, 1])), control=number, value=value)

    events = [(int(rng.choice(samples)), message()) for _ in range(400)]
    for _ in range(6):          # a bend range set with its cents (RPN 0: CC 101, 100, 6, 38), then bends
        at, ch = int(rng.choice(samples)), int(rng.choice([0, 15, 1, 2]))
        events += [(at, mido.Message("control_change", channel=ch, control=c, value=v))
                   for c, v in ((101, 0), (100, 0), (6, int(rng.integers(0, 49))), (38, int(rng.integers(0, 100))))]
        events += [(at + 1, mido.Message("pitchwheel", channel=c, pitch=int(rng.integers(-8192, 8192)))) for c in (ch, 2)]
    return sorted(events, key=lambda e: e[0])


@pytest.fixture(scope="module")
def builds(tmp_path_factory, c_export_module):
    """{mpe mode: (patch folder, the C built with the tests' driver)}; built once."""
    out = {}
    for mpe in ("off", "lower", "upper", "auto"):
        folder = tmp_path_factory.mktemp(f"midi_{mpe}")
        (folder / "patch.yaml").write_text(patch_text(mpe), encoding="utf-8")
        write_midi_file(folder / "take.mid", [], RATE)
        out[mpe] = (folder, c_export_module(folder / "patch.yaml", f"fuzz_{mpe}"))
    return out


@pytest.mark.parametrize("mpe", ["off", "lower", "upper", "auto"])
@pytest.mark.parametrize("seed", range(6))
def test_fuzzed_events_give_the_columns_of_the_python_run(builds, mpe, seed, same_bits):
    folder, built = builds[mpe]
    assert built.lowered.inputs == [] and f"int fuzz_{mpe}_midi(" in built.lowered.header
    write_midi_file(folder / "take.mid", fuzzed(seed), RATE)
    events = read_midi_file(folder / "take.mid", RATE)          # the events as the Python run reads them
    patch = hapticgraph.load(folder / "patch.yaml")
    got = built.run(RATE, SAMPLES, block=1000, midi=events)
    for chunk in (64, 1000):
        audio = hapticgraph.render(patch, SAMPLES / RATE, chunk=chunk).audio
        assert same_bits(got, audio), (chunk, np.argwhere(got != audio)[:5])
    gates = got[:, [OUTPUTS.index("gate") + 5 * k for k in range(2 + VOICES)]]
    assert gates.max() == 1.0 and (np.diff(gates, axis=0) != 0).sum() > 10       # notes came and went


@pytest.mark.parametrize("mpe", ["off", "auto"])
def test_chords_larger_than_the_group_steal_as_python_does(builds, mpe, same_bits):
    """20 keys struck at one sample on three voices already sounding (each voice stolen six or
    seven times in that sample; the C once wrote a dip per steal past its array), released at
    another, struck again with a note-off of the same key at that sample."""
    folder, built = builds[mpe]
    ch = 1
    events = [(10, mido.Message("note_on", channel=ch, note=40 + k, velocity=90)) for k in range(3)]
    events += [(20, mido.Message("note_on", channel=ch, note=60 + k, velocity=50 + k)) for k in range(20)]
    events += [(30, mido.Message("note_off", channel=ch, note=60 + k)) for k in range(20)]
    events += [(40, m) for k in range(20) for m in (mido.Message("note_on", channel=ch, note=60 + k, velocity=99),
                                                     mido.Message("note_off", channel=ch, note=60 + k))]
    write_midi_file(folder / "take.mid", events, RATE)
    got = built.run(RATE, 100, block=100, midi=read_midi_file(folder / "take.mid", RATE))
    expected = hapticgraph.render(hapticgraph.load(folder / "patch.yaml"), 100 / RATE, chunk=64).audio
    v1 = 2 * len(OUTPUTS) + OUTPUTS.index("gate")
    assert got[19, v1] == 0.0 and got[20, v1] == 1.0                 # the dip before the stolen voice's onset
    assert same_bits(got, expected)


def test_an_event_for_a_sample_already_read_falls_on_the_next(builds, same_bits):
    """A voice allocator reads one sample past each call: a note-on given at offset 0 of the call
    after (as an LV2 host gives a call's events) sounds one sample late, as a live port's would."""
    folder, built = builds["off"]
    note = mido.Message("note_on", note=60, velocity=100)
    on_time = built.run(RATE, 3000, block=1000, midi=[(1000, note)])      # given with the call before
    late = built.run(RATE, 3000, block=1000, midi=[(1001, note)])
    gate = OUTPUTS.index("gate")
    v1 = 2 * len(OUTPUTS) + gate
    assert on_time[999, v1] == 0.0 and on_time[1000, v1] == 1.0
    assert late[1000, v1] == 0.0 and late[1001, v1] == 1.0
    # the newest-key block does not read ahead: a note-on at a call's first sample is on time
    assert on_time[1000, gate] == 1.0 and on_time[999, gate] == 0.0


CHECKS = r"""
#include <stdio.h>
#include "fuzz_off.h"
int main(void)
{
    unsigned char on[3] = {0x90, 60, 100}, clock[1] = {0xF8}, bad[3] = {0x90, 200, 1}, data[2] = {60, 1};
    fuzz_off *s = fuzz_off_new(48000.0);
    int k, full = 0;
    printf("%d %d %d %d %d\n", fuzz_off_midi(s, 0, on, 3), fuzz_off_midi(s, 0, clock, 1), fuzz_off_midi(s, 0, bad, 3),
           fuzz_off_midi(s, 0, on, 2), fuzz_off_midi(s, 0, data, 2));
    for (k = 0; k < 5000 && !full; k++) full = fuzz_off_midi(s, 100 + k, on, 3) == -1;
    printf("%d %d\n", full, k);
    fuzz_off_free(s);
    return 0;
}
"""


def test_what_fuzz_midi_takes_and_refuses(builds):
    """0: queued, or a system message (nobody reads it); -2: not a channel message (a data byte
    over 127, too short, no status byte); -1: the queue's 1024 events are waiting."""
    folder, built = builds["off"]
    folder = built.exe.parent
    (folder / "checks.c").write_text(CHECKS, encoding="utf-8")
    exe = build([folder / "checks.c", folder / "fuzz_off.c"], folder / "checks", extra=["-I", str(folder)])
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "0 0 -2 -2 -2"
    assert out[1] == "1 1024"


def test_one_export_of_poly_strings_plays_its_file_at_48_and_96_khz(c_export, same_bits):
    """Exported at the patch's 44.1 kHz, run at other rates: its file's events at those rates give
    `render` of the patch at that rate (its voices' delays derived again in C), bit for bit."""
    path = ROOT / "patches" / "poly_strings.yaml"
    built = c_export(path)
    text = path.read_text(encoding="utf-8")
    for rate in (48000, 96000):
        patch = load(path, text=re.sub(r"(?m)^rate: .*$", f"rate: {rate}", text))
        events = read_midi_file(ROOT / "patches" / "poly_chords.mid", rate)
        expected = hapticgraph.render(patch, 0.5).audio
        assert np.abs(expected).max() > 0.1
        assert same_bits(built.run(rate, len(expected), block=512, midi=events), expected)


GARBAGE = r"""
#include <stdio.h>
#include <stdlib.h>
#include "fuzz_auto.h"
/* bytes that are and are not MIDI (NULL, short, data bytes over 127, system messages, RPN and NRPN
   selections), offsets before, inside and far past the call, calls of 1 to 700 samples, resets */
int main(int argc, char **argv)
{
    double *out[FUZZ_AUTO_N_OUTPUTS + 1];
    int c, k, r, codes[3] = {0, 0, 0};
    fuzz_auto *s = fuzz_auto_new(48000.0);
    srand((unsigned)atoi(argv[1]));
    for (c = 0; c < FUZZ_AUTO_N_OUTPUTS; c++) out[c] = calloc(700, sizeof(double));
    for (k = 0; k < 3000; k++) {
        int n = 1 + rand() % 700, m = rand() % 40;
        for (r = 0; r < m; r++) {
            unsigned char b[3];
            b[0] = (unsigned char)(rand() % 3 ? 0x80 + rand() % 0x70 : rand() % 256);
            b[1] = (unsigned char)(rand() % 8 ? rand() % 128 : rand() % 256);
            b[2] = (unsigned char)(rand() % 8 ? rand() % 128 : rand() % 256);
            if (rand() % 3 == 0) { b[0] = (unsigned char)(0xB0 | rand() % 16); b[1] = (unsigned char)(98 + rand() % 4); }
            codes[-fuzz_auto_midi(s, rand() % 2000 - 100, rand() % 20 ? b : NULL, rand() % 4)]++;
        }
        if (rand() % 20 == 0) {             /* a chord of 40 keys at one sample: every voice stolen again and again */
            int at = rand() % 700;
            for (r = 0; r < 40; r++) {
                unsigned char b[3];
                b[0] = (unsigned char)(0x90 | rand() % 3); b[1] = (unsigned char)(30 + r); b[2] = 100;
                codes[-fuzz_auto_midi(s, at, b, 3)]++;
            }
        }
        fuzz_auto_process(s, NULL, out, n);
        if (rand() % 200 == 0) fuzz_auto_reset(s);
    }
    printf("%d %d %d\n", codes[0], codes[1], codes[2]);
    fuzz_auto_free(s);
    for (c = 0; c < FUZZ_AUTO_N_OUTPUTS; c++) free(out[c]);
    return 0;
}
"""


def test_garbage_midi_under_address_and_undefined_behaviour_sanitizers(builds, tmp_path):
    """The MIDI driver in C takes whatever a host gives it: 3,000 calls with 60,000 random byte
    strings and chords of 40 keys at one sample, built with -fsanitize=address,undefined (any
    report fails the run)."""
    _, built = builds["auto"]
    folder = built.exe.parent
    (tmp_path / "fuzz_auto.h").write_text((folder / "fuzz_auto.h").read_text(encoding="utf-8"), encoding="utf-8")
    (tmp_path / "garbage.c").write_text(GARBAGE, encoding="utf-8")
    exe = tmp_path / "garbage"
    subprocess.run(compiler() + ["-std=c99", "-g", "-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
                                 str(tmp_path / "garbage.c"), str(folder / "fuzz_auto.c"), "-I", str(tmp_path),
                                 "-o", str(exe), "-lm"], check=True, capture_output=True, timeout=300)
    for seed in (1, 2):
        proc = subprocess.run([str(exe), str(seed)], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        queued, full, refused = map(int, proc.stdout.split())
        assert queued > 10000 and refused > 10000
