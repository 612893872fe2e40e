"""Every shipped patch that exports (the waveguides, and the lattices whose groups' steps the
translator reads) gives in C the bits of the Python run: its device is a driver, so the C reads in `in` what the Python run's drivers produced — the simulated device's
position, velocity and axes (probed from its model), a MIDI file's columns (Session.inputs) —
and its audio and the forces it sends (Session.forces) are compared bit for bit.

The same export built to WebAssembly runs in wasmtime: bit for bit too, but where wasi-libc's libm
(musl's sin, cos, exp, pow: 1 ulp from glibc's on a few arguments in a hundred) rounds otherwise than
the system's, a patch that feeds such a value back drifts by a few ulps: within WASM_DRIFT of its peak
after a second (docs/export.md, "Same numbers"). The forces stay the same bits in every patch."""
import os

import numpy as np
import pytest

import hapticgraph
from hapticgraph.devices.midi import read_midi_file
from project_env import ROOT

WAVEGUIDES = ["buzz_50hz", "feedback_comb", "fig7_bowed_string", "fig8_pluck_damp", "midi_melody",
              "plucked_string", "poly_strings", "string_bound_explicit", "string_bound_implicit"]
# fused mass-spring groups: their step functions translated the same way (stencils, CSR networks,
# the nonlinear links' loops blocks/massspring/laws.py makes from text)
LATTICES = ["babe_is_sleeping", "bowed_lattice_string", "cymatic_block", "cymatic_sheet", "cymatic_string",
            "force_feedback_mic", "hyper_4d", "piano_hammer", "string_drives_plate", "string_rattle"]
# what a haptic block outputs of its sensor columns (blocks/device.py: Haptic.output)
SENSOR = {"sensor_x": "x", "sensor_v": "v"}
# the patches whose audio in wasm is not the bits of the Python run (musl's libm), and their bound:
# measured over 1 s, the largest |wasm - python| / peak is 2.5e-9 (string_rattle's nonlinear rattle
# amplifies a first 1-ulp sin); the others stay below 2e-13
LIBM_DRIFT = {"feedback_comb", "midi_melody", "poly_strings", "cymatic_string", "string_rattle"}
WASM_DRIFT = 1e-8


def _device_probes(patch, lowered):
    """{C input index: probe} for the columns a device model computes inside Python's kernel."""
    probes = {}
    for k, port in enumerate(lowered.inputs):
        device, _, column = port.name.partition(".")
        bound = [b for b in patch.blocks.values() if any(
            p.refers == "devices" and b.values.get(n) == device for n, p in b.cls.params.items())]
        if bound:
            probes[k] = f"{bound[0].name}.{SENSOR.get(column, column)}"
    return probes


def midi_events(patch, rate):
    """The (sample, message) events of the patch's MIDI file, as the Python run reads them: what a
    host gives NAME_midi (None when the patch has no MIDI device)."""
    files = [spec["file"] for spec in (patch.devices or {}).values() if spec.get("driver") == "midi" and spec.get("file")]
    if not files:
        return None
    assert len(files) == 1                    # NAME_midi is one stream: every MIDI device hears it
    return read_midi_file(os.path.join(os.path.dirname(str(patch.file)), files[0]), rate)


def python_run(path, lowered, seconds, block, patch=None):
    """(audio, forces, device inputs, rate) of the patch at `path` (or `patch`, loaded already) run
    by a Session for `seconds`, in blocks of `block`."""
    patch = patch or hapticgraph.load(path)
    probes = _device_probes(patch, lowered)
    # not editable: a lattice runs its stencil, as `hapticgraph run` does (editable: the general path)
    with hapticgraph.Session.open(patch, probes=sorted(set(probes.values())), blocksize=block, editable=False) as s:
        columns = {f"{d}.{c}": j for j, (d, c) in enumerate(s.program.ext_columns)}
        audio, forces, inputs = [], [], []
        for _ in range(round(seconds * s.rate) // block):
            out = s.process(block)
            probed = s.probes_of(out)
            row = np.zeros((block, len(lowered.inputs)))
            for k, port in enumerate(lowered.inputs):
                row[:, k] = probed[probes[k]] if k in probes else s.inputs[:, columns[port.name]]
            audio.append(np.array(s.audio_of(out)))
            forces.append(np.array(s.forces))
            inputs.append(row)
    return np.concatenate(audio), np.concatenate(forces), np.concatenate(inputs), s.rate


@pytest.mark.parametrize("name", WAVEGUIDES + LATTICES)
def test_waveguide_patch_in_c_and_wasm_gives_the_bits_of_the_python_run(name, c_export, wasm_export, same_bits):
    path = ROOT / "patches" / f"{name}.yaml"
    built = c_export(path)
    module = wasm_export(path)
    lowered = built.lowered
    block = 950
    audio, forces, inputs, rate = python_run(path, lowered, 1.0, block)
    events = midi_events(hapticgraph.load(path), rate)
    got = built.run(rate, len(audio), block=block, inputs=inputs, midi=events)
    channels = audio.shape[1]
    assert np.abs(audio).max() > 0.0                      # it sounds
    assert same_bits(got[:, :channels], audio)
    assert same_bits(got[:, channels:], forces)
    prog = lowered.prog
    if any(prog.records[col][1].terms for _, col in prog.device_records):
        assert np.abs(forces).max() > 0.0                 # a force was sent where something drives one
    in_wasm = module.run(rate, len(audio), block=block, inputs=inputs, midi=events)
    assert same_bits(in_wasm[:, channels:], forces)
    if name in LIBM_DRIFT:
        assert np.abs(in_wasm[:, :channels] - audio).max() <= WASM_DRIFT * np.abs(audio).max()
    else:
        assert same_bits(in_wasm[:, :channels], audio)
