"""The LV2 plugin of a patch with MIDI blocks has an atom MIDI input (`midi_in`, urid:map
required). lv2info lists it; a small LV2 host (below: dlopen, lv2_descriptor, a URID map, an
atom sequence per run, as any host builds one) plays a MIDI file's events through it, each
run's events at their frames, and its output is `hapticgraph render` of that file rounded to
float32 — in a patch with `voices:`, with the documented exception: a note-on at a run's first
frame sounds one frame later (its allocator read that frame in the run before). Live, jalv hosts
it under a dummy JACK server and a note sent to its MIDI input from python-rtmidi sounds."""
import os
import subprocess
import uuid

import numpy as np
import pytest
import rtmidi
import soundfile

import hapticgraph
from hapticgraph.cli.main import main
from hapticgraph.devices.midi import read_midi_file, write_midi_file
from hapticgraph.export.bundle import lower
from hapticgraph.export.compiler import build
from hapticgraph.export.lv2 import URI
from jack_server import jack_server, stop, until
from project_env import ROOT

HOST = r"""
#define _POSIX_C_SOURCE 200809L       /* strdup, dlopen */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <lv2/core/lv2.h>
#include <lv2/atom/atom.h>
#include <lv2/atom/util.h>
#include <lv2/midi/midi.h>
#include <lv2/urid/urid.h>

static char *uris[256];
static int n_uris;

static LV2_URID map_uri(LV2_URID_Map_Handle handle, const char *uri)
{
    int k;
    (void)handle;
    for (k = 0; k < n_uris; k++) if (strcmp(uris[k], uri) == 0) return (LV2_URID)(k + 1);
    uris[n_uris] = strdup(uri);
    return (LV2_URID)++n_uris;
}

/* SO URI BUNDLE RATE TOTAL RUN N_IN N_OUT EVENTS.bin [CONTROL]... : the outputs (float32, row by
   row); EVENTS: 5 int64 each (frame, length, 3 bytes), in order; the MIDI port after the controls */
int main(int argc, char **argv)
{
    LV2_URID_Map map = {NULL, map_uri};
    LV2_Feature map_feature = {LV2_URID__map, &map};
    const LV2_Feature *features[] = {&map_feature, NULL};
    LV2_Descriptor_Function get;
    const LV2_Descriptor *d = NULL;
    LV2_Handle h;
    long total = atol(argv[5]), done, n_events, next = 0, k;
    int run = atoi(argv[6]), n_in = atoi(argv[7]), n_out = atoi(argv[8]), n_ctl = argc - 10, c, m;
    float **in = calloc((size_t)n_in + 1, sizeof *in), **out = calloc((size_t)n_out + 1, sizeof *out);
    float *ctl = calloc((size_t)n_ctl + 1, sizeof *ctl);
    long long *events;
    union { LV2_Atom_Sequence seq; unsigned char bytes[1 << 16]; } *buffer = calloc(1, sizeof *buffer);
    LV2_URID sequence = map_uri(NULL, LV2_ATOM__Sequence), midi = map_uri(NULL, LV2_MIDI__MidiEvent);
    FILE *f = fopen(argv[9], "rb");
    void *lib = dlopen(argv[1], RTLD_NOW);
    if (lib == NULL || f == NULL) return 2;
    fseek(f, 0, SEEK_END);
    n_events = ftell(f) / 40;
    rewind(f);
    events = calloc((size_t)n_events * 5 + 1, sizeof *events);
    if (fread(events, 8, (size_t)n_events * 5, f) != (size_t)n_events * 5) return 2;
    get = (LV2_Descriptor_Function)dlsym(lib, "lv2_descriptor");
    for (k = 0; (d = get((uint32_t)k)) != NULL; k++) if (strcmp(d->URI, argv[2]) == 0) break;
    if (d == NULL) return 3;
    h = d->instantiate(d, atof(argv[4]), argv[3], features);
    if (h == NULL) return 4;
    for (c = 0; c < n_in; c++) { in[c] = calloc((size_t)run, sizeof(float)); d->connect_port(h, (uint32_t)c, in[c]); }
    for (c = 0; c < n_out; c++) { out[c] = calloc((size_t)run, sizeof(float)); d->connect_port(h, (uint32_t)(n_in + c), out[c]); }
    for (c = 0; c < n_ctl; c++) { ctl[c] = (float)atof(argv[10 + c]); d->connect_port(h, (uint32_t)(n_in + n_out + c), &ctl[c]); }
    d->connect_port(h, (uint32_t)(n_in + n_out + n_ctl), &buffer->seq);
    if (d->activate) d->activate(h);
    for (done = 0; done < total; done += m) {
        m = total - done < run ? (int)(total - done) : run;
        buffer->seq.atom.type = sequence;
        buffer->seq.atom.size = sizeof(LV2_Atom_Sequence_Body);
        buffer->seq.body.unit = 0;
        buffer->seq.body.pad = 0;
        for (; next < n_events && events[next * 5] < done + m; next++) {
            /* the next event: after the body's header and the events so far (atom.size counts both) */
            LV2_Atom_Event *ev = (LV2_Atom_Event *)((unsigned char *)LV2_ATOM_CONTENTS(LV2_Atom_Sequence, &buffer->seq)
                                                    + (buffer->seq.atom.size - sizeof(LV2_Atom_Sequence_Body)));
            unsigned char *body = (unsigned char *)(ev + 1);
            ev->time.frames = events[next * 5] - done;
            ev->body.type = midi;
            ev->body.size = (uint32_t)events[next * 5 + 1];
            for (c = 0; c < (int)ev->body.size; c++) body[c] = (unsigned char)events[next * 5 + 2 + c];
            buffer->seq.atom.size += (uint32_t)lv2_atom_pad_size(sizeof(LV2_Atom_Event) + ev->body.size);
        }
        d->run(h, (uint32_t)m);
        for (k = 0; k < m; k++) for (c = 0; c < n_out; c++) fwrite(&out[c][k], sizeof(float), 1, stdout);
    }
    if (d->deactivate) d->deactivate(h);
    d->cleanup(h);
    return 0;
}
"""

RATE = 44100
SECONDS = 1.0


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lv2_host")
    (folder / "host.c").write_text(HOST, encoding="utf-8")
    return build([folder / "host.c"], folder / "host", extra=["-ldl"])


def _bundle(tmp_path, name):
    assert main(["export", str(ROOT / "patches" / f"{name}.yaml"), "--to", "lv2", "--out", str(tmp_path / "lv2")]) == 0
    return tmp_path / "lv2" / f"{name}.lv2"


def _play(host, bundle, name, events, run, tmp_path):
    """The plugin's outputs (float32, frames × outputs) for `events` ((frame, mido.Message)), in runs of `run`."""
    lowered = lower(hapticgraph.load(ROOT / "patches" / f"{name}.yaml"), name)
    controls = [repr(p.default) for p in lowered.params if p.slot >= 0]
    rows = [[at, len(m.bytes())] + (m.bytes() + [0, 0])[:3] for at, m in events]
    path = tmp_path / "events.bin"
    np.array(rows, dtype=np.int64).reshape(-1, 5).tofile(path)
    total = round(SECONDS * RATE)
    args = [str(host), str(bundle / f"{name}.so"), f"urn:hapticgraph:{name}", str(bundle) + "/", repr(float(RATE)),
            str(total), str(run), str(len(lowered.inputs)), str(len(lowered.outputs)), str(path), *controls]
    proc = subprocess.run(args, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return np.frombuffer(proc.stdout, dtype=np.float32).reshape(total, len(lowered.outputs))


def _render(name, events, tmp_path):
    """`hapticgraph render` of the patch playing `events` written as its MIDI file."""
    folder = tmp_path / "py"
    folder.mkdir(exist_ok=True)
    text = (ROOT / "patches" / f"{name}.yaml").read_text(encoding="utf-8")
    midi = hapticgraph.load(ROOT / "patches" / f"{name}.yaml").devices
    original = next(spec["file"] for spec in midi.values() if spec.get("driver") == "midi")
    (folder / f"{name}.yaml").write_text(text.replace(original, "take.mid"), encoding="utf-8")
    write_midi_file(folder / "take.mid", events, RATE)
    return hapticgraph.render(hapticgraph.load(folder / f"{name}.yaml"), SECONDS).audio


def _events(name):
    patch = hapticgraph.load(ROOT / "patches" / f"{name}.yaml")
    spec = next(spec for spec in patch.devices.values() if spec.get("driver") == "midi")
    return read_midi_file(os.path.join(os.path.dirname(str(patch.file)), spec["file"]), RATE)


def test_lv2info_lists_the_atom_midi_input(tmp_path):
    bundle = _bundle(tmp_path, "midi_melody")
    proc = subprocess.run(["lv2info", "urn:hapticgraph:midi_melody"], env=dict(os.environ, LV2_PATH=str(bundle.parent)),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    port = proc.stdout[proc.stdout.index("Port 2:"):]
    assert "ext/atom#AtomPort" in port and "lv2core#InputPort" in port and "midi_in" in port
    assert "Required Features: http://lv2plug.in/ns/ext/urid#map" in proc.stdout
    ttl = (bundle / "midi_melody.ttl").read_text(encoding="utf-8")
    assert "atom:bufferType atom:Sequence" in ttl and "atom:supports midi:MidiEvent" in ttl


@pytest.mark.parametrize("name", ["midi_melody", "fig8_pluck_damp", "karplus_strong"])
def test_lv2_validate_finds_no_error_in_the_bundle(tmp_path, name):
    """lv2-dev's lv2_validate (sord_validate, Debian's sordi, against the installed LV2 specs): the
    manifest and the plugin's description, MIDI, CV and control ports, hold every restriction."""
    bundle = _bundle(tmp_path, name)
    proc = subprocess.run(["lv2_validate", str(bundle / "manifest.ttl"), str(bundle / f"{name}.ttl")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "Found 0 errors" in proc.stdout + proc.stderr, proc.stdout + proc.stderr


@pytest.mark.parametrize("run", [256, 1000])
def test_midi_melody_in_an_lv2_host_is_render_of_its_file_in_float32(host, tmp_path, run):
    """The newest-key block reads no frame ahead: every event at its frame, whatever the runs."""
    bundle = _bundle(tmp_path, "midi_melody")
    events = _events("midi_melody")
    got = _play(host, bundle, "midi_melody", events, run, tmp_path)
    expected = _render("midi_melody", events, tmp_path)
    assert np.abs(expected).max() > 0.1
    assert np.array_equal(got, expected.astype(np.float32))


def test_poly_strings_note_ons_at_a_runs_first_frame_sound_one_frame_later(host, tmp_path):
    """Six voices: runs of 441 frames; the chords' note-ons that fall on a run's first frame are
    moved one frame later in the render it equals; the others play at their frames."""
    bundle = _bundle(tmp_path, "poly_strings")
    run = 441
    events = _events("poly_strings")
    on_boundary = [at for at, m in events if at % run == 0 and at > 0]
    assert on_boundary                              # the chords begin on whole hundredths of a second
    got = _play(host, bundle, "poly_strings", events, run, tmp_path)
    later = [(at + 1 if at % run == 0 and at > 0 else at, m) for at, m in events]
    expected = _render("poly_strings", later, tmp_path)
    assert np.abs(expected).max() > 0.1
    assert np.array_equal(got, expected.astype(np.float32))
    assert not np.array_equal(got, _render("poly_strings", events, tmp_path).astype(np.float32))


def test_jalv_plays_a_note_sent_to_its_midi_input(tmp_path, monkeypatch):
    """jalv under a dummy JACK server; a python-rtmidi JACK client connected to the plugin's
    midi_in holds A4: jack_rec hears the melody's sine at 440 Hz (silence before the note)."""
    bundle = _bundle(tmp_path, "midi_melody")
    client = f"hgmm{uuid.uuid4().hex[:6]}"
    with jack_server(tmp_path, 48000, 256) as env, open(tmp_path / "jalv.log", "w") as jalv_log:
        for key in ("JACK_DEFAULT_SERVER", "JACK_NO_START_SERVER"):
            monkeypatch.setenv(key, env[key])               # python-rtmidi's JACK client reaches it too
        jalv = subprocess.Popen(["jalv", "-x", "-n", client, URI.format(name="midi_melody")],
                                env=dict(env, LV2_PATH=str(bundle.parent)), stdin=subprocess.PIPE,
                                stdout=jalv_log, stderr=subprocess.STDOUT)
        keys = None
        try:
            ports = lambda: subprocess.run(["jack_lsp"], env=env, capture_output=True, text=True, timeout=10).stdout
            until(lambda: f"{client}:midi_in" in ports() and f"{client}:out_ch0" in ports(), 30,
                  "jalv's ports did not appear")
            silent = _record(env, f"{client}:out_ch0", tmp_path / "before.wav")
            keys = rtmidi.MidiOut(rtmidi.API_UNIX_JACK, name="hgkeys")
            keys.open_virtual_port("out")
            port = next(p for p in ports().split("\n") if p.startswith("hgkeys") and p.endswith(":out"))
            subprocess.run(["jack_connect", port, f"{client}:midi_in"], env=env, check=True, timeout=10)
            keys.send_message([0x90, 69, 100])
            played = _record(env, f"{client}:out_ch0", tmp_path / "after.wav")
            keys.send_message([0x80, 69, 0])
        finally:
            if keys is not None:
                keys.close_port()
                keys.delete()
            stop(jalv)
    assert np.abs(silent).max() == 0.0
    loud = played[np.abs(played) > 0.05]
    assert len(loud) > 10000                               # the note sounds, enveloped to 0.3
    spectrum = np.abs(np.fft.rfft(played[-32768:]))
    assert abs(np.argmax(spectrum) * 48000 / 32768 - 440.0) < 3.0


def _record(env, port, path):
    subprocess.run(["jack_rec", "-f", str(path), "-d", "1", "-b", "32", port], env=env, check=True,
                   capture_output=True, timeout=60)
    recorded, _ = soundfile.read(path, dtype="float64")
    return recorded
