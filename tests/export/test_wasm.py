"""`--to wasm`: NAME.wasm imports nothing and exports the C API and its buffer interface; NAME.js
plays it in an AudioWorklet; index.html loads it from a static server. In headless Chromium
(an OfflineAudioContext rendered and read back) the worklet gives the Python run's samples: its
float64 outputs bit for bit, the rendered float32 buffer as their rounding, with the device's
rows and a live change sent by message. (wasmtime runs every
shipped patch's module in test_c_waveguides.py, beside the native C.)"""
import base64
import contextlib
import functools
import http.server
import threading

import numpy as np
import pytest

import hapticgraph
from browser_env import chromium
from hapticgraph.cli.main import main
from hapticgraph.export.wasm import API
from hapticgraph.graph.c import export_c
from project_env import ROOT
from test_c_waveguides import LATTICES, LIBM_DRIFT, WASM_DRIFT, WAVEGUIDES, midi_events, python_run

KS = ROOT / "patches" / "karplus_strong.yaml"
FIG8 = ROOT / "patches" / "fig8_pluck_damp.yaml"
QUANTUM = 128         # the Web Audio render quantum: the worklet's block

RENDER = """
const done = arguments[arguments.length - 1];
const [length, rate, channels, inputs, sets, suspendAt, midi, midiByMessage] = arguments;
const bytes = (b64) => Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)).buffer;
const b64 = (buffer) => {
  const u = new Uint8Array(buffer);
  let s = '';
  for (let i = 0; i < u.length; i += 0x8000) s += String.fromCharCode.apply(null, u.subarray(i, i + 0x8000));
  return btoa(s);
};
(async () => {
  const context = new OfflineAudioContext(channels, length, rate);
  const node = await window.hapticgraph.start(context, midi && !midiByMessage ? {record: true, midi} : {record: true});
  const records = [], errors = [], acks = {};
  node.port.onmessage = (e) => {
    if (e.data.out) records.push(e.data);
    if (e.data.error || e.data.fault) errors.push(JSON.stringify(e.data));
    if (e.data.ack !== undefined) acks[e.data.ack] = e.data.frame;
  };
  let id = 0;
  const send = async (message) => {            // posted, and its acknowledgement awaited
    const mine = id++;
    node.port.postMessage({...message, id: mine});
    const start = Date.now();
    while (!(mine in acks) && Date.now() - start < 10000) await new Promise((r) => setTimeout(r, 5));
    return acks[mine];
  };
  if (inputs) await send({input: new Float64Array(bytes(inputs))});       // the device's rows, queued
  if (midi && midiByMessage) for (const [frame, ...data] of midi) await send({midi: data, frame});
  const applied = [];
  if (sets.length) {
    context.suspend(suspendAt).then(async () => {    // rendering stopped: the sets reach the next quantum
      for (const [index, value] of sets) applied.push(await send({set: [index, value]}));
      context.resume();
    });
  }
  const buffer = await context.startRendering();
  const need = Math.ceil(length / 128), start = Date.now();
  while (records.length < need && Date.now() - start < 30000) await new Promise((r) => setTimeout(r, 50));
  records.sort((a, b) => a.frame - b.frame);
  const all = new Float64Array(records.reduce((n, r) => n + r.out.length, 0));
  let at = 0;
  for (const r of records) { all.set(r.out, at); at += r.out.length; }
  const audio = new Float32Array(length * channels);
  for (let c = 0; c < channels; c++) audio.set(buffer.getChannelData(c), c * length);
  done({errors, applied, frames: records.map((r) => r.frame), records: b64(all.buffer), audio: b64(audio.buffer)});
})().catch((e) => done({errors: [String(e)], applied: [], frames: [], records: '', audio: ''}));
"""


@contextlib.contextmanager
def static_server(folder):
    """A static server on loopback for `folder` (what index.html needs: no server beyond that)."""
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


def _render_in_chromium(folder, tmp_path, length, rate, outputs, channels, inputs=None, sets=(), at=0.0, midi=None,
                        midi_by_message=False):
    """The worklet's records (float64, length × outputs), the rendered buffer (float32, length ×
    channels) and the frames the sets applied from. The device's rows go by one message before
    rendering; the sets by messages while the rendering is suspended at `at` seconds; MIDI events
    ((frame, mido.Message)) in processorOptions.midi, or each by a message {midi, frame} before
    rendering (`midi_by_message`)."""
    midi = None if midi is None else [[at_, *(m.bytes() + [0, 0])[:3]] for at_, m in midi]
    with static_server(folder) as url, chromium(tmp_path) as driver:
        driver.get(url + "index.html")
        assert driver.execute_script("return document.body.dataset.ready") == "1"
        encoded = None if inputs is None else base64.b64encode(np.ascontiguousarray(inputs, "<f8").tobytes()).decode()
        got = driver.execute_async_script(RENDER, length, rate, channels, encoded, [list(s) for s in sets], at, midi,
                                          midi_by_message)
    assert got["errors"] == [], got["errors"]
    assert got["frames"] == list(range(0, length + QUANTUM - 1, QUANTUM))[:len(got["frames"])]
    blocks = np.frombuffer(base64.b64decode(got["records"]), "<f8").reshape(-1, outputs, QUANTUM)
    records = blocks.transpose(0, 2, 1).reshape(-1, outputs)[:length]
    audio = np.frombuffer(base64.b64decode(got["audio"]), "<f4").reshape(channels, length).T
    return records, audio, got["applied"]


def test_the_module_imports_nothing_and_exports_the_api(tmp_path, wasm_export, capsys):
    assert main(["export", str(KS), "--to", "wasm", "--out", str(tmp_path / "ks")]) == 0
    written = capsys.readouterr().out.split()
    assert sorted(p.rsplit("/", 1)[-1] for p in written) == sorted(
        ["karplus_strong.h", "karplus_strong.c", "karplus_strong_host.c", "karplus_strong.js", "index.html",
         "karplus_strong.wasm"])
    built = wasm_export(KS)
    assert built.imports() == []
    exports = {e.name for e in built.module.exports}
    assert exports >= {f"karplus_strong_{f}" for f in API} | {"malloc", "free", "memory"}
    built.run(50.0, 10, expect=3)                       # the rate refused, as NAME_new refuses it
    built.run(44100, 10, sets=[(0, 99, 0.0)], expect=4)


def test_karplus_strong_in_the_worklet_gives_the_bits_of_render(tmp_path, same_bits):
    """A live change by message while the rendering is suspended: it applies from the next
    quantum (the frame the worklet acknowledges), as Session.set applies at a block boundary."""
    assert main(["export", str(KS), "--to", "wasm", "--out", str(tmp_path / "ks")]) == 0
    gain = [p.name for p in export_c(hapticgraph.load(KS), "karplus_strong").params].index("damp.gain")
    length = 300 * QUANTUM
    records, audio, applied = _render_in_chromium(tmp_path / "ks", tmp_path, length, 44100, 2, 2,
                                                  sets=[(gain, 0.9)], at=100 * QUANTUM / 44100)
    assert len(applied) == 1 and applied[0] % QUANTUM == 0 and 0 < applied[0] < length, applied
    with hapticgraph.Session.open(KS, blocksize=QUANTUM) as s:
        blocks = []
        for k in range(length // QUANTUM):
            if k * QUANTUM == applied[0]:
                s.set("damp", "gain", 0.9)
            blocks.append(np.array(s.audio_of(s.process(QUANTUM))))
    expected = np.concatenate(blocks)
    assert np.abs(expected).max() > 0.1
    assert same_bits(records, expected)                         # float64 in the worklet: the bits
    assert same_bits(audio, expected.astype(np.float32))        # what Web Audio plays: their rounding
    unchanged = hapticgraph.render(KS, seconds=length / 44100).audio
    assert not same_bits(records[applied[0]:], unchanged[applied[0]:length])     # the change was heard


def test_fig8_in_the_worklet_takes_its_finger_by_message_and_sends_its_force(tmp_path, wasm_export, same_bits):
    assert main(["export", str(FIG8), "--to", "wasm", "--out", str(tmp_path / "fig8")]) == 0
    built = wasm_export(FIG8)
    audio, forces, inputs, rate = python_run(FIG8, built.lowered, 0.5, 950)
    channels = audio.shape[1]
    records, played, _ = _render_in_chromium(tmp_path / "fig8", tmp_path, len(audio), rate,
                                             len(built.lowered.outputs), channels, inputs=inputs)
    assert np.abs(audio).max() > 0.0 and np.abs(forces).max() > 0.0
    assert same_bits(records[:, :channels], audio)
    assert same_bits(records[:, channels:], forces)
    assert same_bits(played, audio.astype(np.float32))


@pytest.mark.parametrize("name", WAVEGUIDES + LATTICES)
def test_every_patch_in_the_worklet_gives_what_wasmtime_gives(name, tmp_path, wasm_export, same_bits):
    """The sameness test of test_c_waveguides.py in the browser: half a second of each shipped
    patch, its device's rows by message; the bits of the Python run, or within the libm drift."""
    path = ROOT / "patches" / f"{name}.yaml"
    assert main(["export", str(path), "--to", "wasm", "--out", str(tmp_path / name)]) == 0
    built = wasm_export(path)
    assert all(p.kind != "audio" for p in built.lowered.inputs)       # every input is a device's row
    audio, forces, inputs, rate = python_run(path, built.lowered, 0.5, 950)
    events = midi_events(hapticgraph.load(path), rate)
    channels = audio.shape[1]
    records, played, _ = _render_in_chromium(tmp_path / name, tmp_path, len(audio), rate, len(built.lowered.outputs),
                                             channels, inputs=inputs if len(built.lowered.inputs) else None,
                                             midi=events)
    assert np.abs(audio).max() > 0.0
    assert same_bits(records, built.run(rate, len(audio), block=950, inputs=inputs, midi=events))   # V8 = wasmtime
    assert same_bits(records[:, channels:], forces)
    if name in LIBM_DRIFT:
        assert np.abs(records[:, :channels] - audio).max() <= WASM_DRIFT * np.abs(audio).max()
    else:
        assert same_bits(records[:, :channels], audio)
        assert same_bits(played, audio.astype(np.float32))


def test_midi_by_message_at_its_frame_plays_as_the_file(tmp_path, wasm_export, same_bits):
    """poly_strings' chords sent to the worklet one message a MIDI event, {midi: bytes, frame},
    before the rendering starts: the bits of the Python run, as given in processorOptions."""
    path = ROOT / "patches" / "poly_strings.yaml"
    assert main(["export", str(path), "--to", "wasm", "--out", str(tmp_path / "ps")]) == 0
    built = wasm_export(path)
    audio, _, _, rate = python_run(path, built.lowered, 0.5, 950)
    events = midi_events(hapticgraph.load(path), rate)
    assert len(events) > 10
    records, _, _ = _render_in_chromium(tmp_path / "ps", tmp_path, len(audio), rate, len(built.lowered.outputs),
                                        audio.shape[1], midi=events, midi_by_message=True)
    assert np.abs(audio).max() > 0.0
    assert np.abs(records - audio).max() <= WASM_DRIFT * np.abs(audio).max()      # poly_strings: musl's libm
