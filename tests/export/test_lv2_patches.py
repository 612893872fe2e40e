"""Every shipped patch as an LV2 plugin in Debian's lilv tools: `lv2info` loads it and lists its
ports as the export made them, and `lv2apply` runs it over a WAV file to hapticgraph's samples
rounded to float32 (LV2 carries float32; the plugin computes in double), with its controls at
their defaults and with one set by `-c SYMBOL VALUE` (as `run --set` sets it).

What lv2apply (lilv 0.24) drives, from its source (tools/lv2apply.c): it refuses a plugin without
an audio input ("Unable to map 1 inputs to 0 ports") and runs one frame per call, reading the
file's rate; it connects each audio port to the file, each control port to its default or its
`-c` value, and an lv2:connectionOptional port of another kind to NULL (any other port: "Port N
has unsupported type"). No shipped patch has an audio input, so each is played here with one
added (`lv2apply_in`, fed from the WAV file); the device's CV ports, optional, are NULL, which the
plugin reads as 0: the Python render feeds the same columns, held at 0 (Held), and the forces
lv2apply drops are not compared. A device held still leaves its instrument silent, so there the
WAV goes into the instrument (INTO); elsewhere the input is left unconnected and the patch sounds
as shipped. The MIDI patches (midi_melody, poly_strings) are not played: their MIDI input is
being redone as an LV2 atom port."""
import os
import re
import subprocess

import numpy as np
import pytest
import soundfile
import yaml

import hapticgraph
from hapticgraph.cli.main import main
from hapticgraph.export.lv2 import URI
from hapticgraph.graph.c import export_c
from hapticgraph.graph.c.drivers import ColumnDriver, column_drivers
from project_env import ROOT

MIDI = {"midi_melody", "poly_strings"}
PATCHES = sorted(p.stem for p in (ROOT / "patches").glob("*.yaml") if p.stem not in MIDI)
INPUT = "lv2apply_in"
SECONDS = 0.2
# where the WAV file is added in a patch whose device held at 0 leaves it silent: a waveguide's
# first delay, a lattice's plucked cell (with the audio_in gain that keeps it in range)
INTO = {
    "babe_is_sleeping": ("str[7].force", 2.0),
    "buzz_50hz": ("r1.in", 0.5),
    "fig7_bowed_string": ("r1.in", 0.5),
    "fig8_pluck_damp": ("r1.in", 0.5),
    "force_feedback_mic": ("str[6].force", 2.0),
    "plucked_string": ("r1.in", 0.5),
}
# a live parameter of each patch set with lv2apply's -c, and its value
CONTROL = {
    "babe_is_sleeping": ("str.damping", 0.005),
    "bowed_lattice_string": ("speed.value", 0.4),
    "buzz_50hz": ("bridge.gain", -0.98),
    "cymatic_block": ("hit.force", 0.5),
    "cymatic_sheet": ("sheet.damping", 0.002),
    "cymatic_string": ("str.damping", 0.002),
    "feedback_comb": ("fb.gain", 0.9),
    "fig7_bowed_string": ("mic.pan", 0.5),
    "fig8_pluck_damp": ("bridge.gain", -0.98),
    "force_feedback_mic": ("str.damping", 0.01),
    "hyper_4d": ("hit1.force", 0.5),
    "karplus_strong": ("damp.gain", 0.99),
    "piano_hammer": ("felt.speed", 1.5),
    "plucked_string": ("nut.gain", -0.9),
    "string_bound_explicit": ("link.k", 80.0),
    "string_bound_implicit": ("j.k", 80.0),
    "string_drives_plate": ("plate.damping", 0.01),
    "string_rattle": ("hit.force", -20.0),
}


class Held(ColumnDriver):
    """A device (or the added audio input) whose columns are given rows: `values[t]` at sample t."""

    def __init__(self, driver, values):
        super().__init__(driver.name, driver.columns, driver.max_force)
        self.values = values

    def fill(self, t0, ext):
        ext[:] = self.values[t0:t0 + len(ext)]


class Bundle:
    """A shipped patch with an audio input added, its WAV file and its LV2 bundle in `folder`."""

    def __init__(self, name, folder):
        self.name, self.folder = name, folder
        text = yaml.safe_load((ROOT / "patches" / f"{name}.yaml").read_text(encoding="utf-8"))
        into, gain = INTO.get(name, (None, 1.0))
        text["blocks"][INPUT] = {"type": "audio_in", "file": "input.wav", "gain": gain}
        if into is not None:
            text["connect"].append(f"{INPUT}.out -> {into}")
        self.patch = folder / f"{name}.yaml"
        self.patch.write_text(yaml.safe_dump(text, sort_keys=False), encoding="utf-8")
        self.rate = int(text["rate"])
        self.wav = np.zeros(round(SECONDS * self.rate), dtype=np.float32)
        self.wav[50:250] = np.random.default_rng(1).uniform(-0.5, 0.5, 200).astype(np.float32)
        soundfile.write(folder / "input.wav", self.wav, self.rate, subtype="FLOAT")
        assert main(["export", str(self.patch), "--to", "lv2", "--out", str(folder / "lv2")]) == 0

    def lilv(self, tool, *args):
        env = dict(os.environ, LV2_PATH=str(self.folder / "lv2"))
        proc = subprocess.run([tool, *args, URI.format(name=self.name)], env=env, capture_output=True, text=True,
                              timeout=120)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout

    def apply(self, controls=()):
        """lv2apply's output over the WAV file (frames × channels, float32 values as float64)."""
        out = self.folder / f"out{len(controls)}.wav"
        args = ["-i", str(self.folder / "input.wav"), "-o", str(out)]
        for symbol, value in controls:
            args += ["-c", symbol, repr(value)]
        self.lilv("lv2apply", *args)
        got, rate = soundfile.read(out, dtype="float64", always_2d=True)
        assert rate == self.rate and soundfile.info(out).subtype == "FLOAT"
        return got

    def render(self, sets=()):
        """The Python render of the same patch: the devices' columns held at 0, the WAV file in."""
        patch = hapticgraph.load(self.patch, overrides=sets)
        drivers = {}
        for device, driver in column_drivers(patch).items():
            values = np.zeros((len(self.wav), len(driver.columns)))
            if device == INPUT:
                values[:, 0] = self.wav
            drivers[device] = Held(driver, values)
        return hapticgraph.render(patch, SECONDS, drivers=drivers).audio


@pytest.fixture(scope="module")
def bundles(tmp_path_factory):
    """bundles(name) -> Bundle, each built once for the module."""
    made = {}

    def get(name):
        if name not in made:
            made[name] = Bundle(name, tmp_path_factory.mktemp(name))
        return made[name]
    return get


def _same_float32(got, expected):
    """lv2apply's samples are the double render rounded once to float32: within half an ulp, 2**-24
    relative, or 2**-150 absolute among float32's subnormals (a lattice's wave front is that small)."""
    assert got.shape == expected.shape
    assert np.array_equal(got, expected.astype(np.float32).astype(np.float64))
    assert np.all(np.abs(got - expected) <= np.maximum(np.abs(expected) * 2.0 ** -24, 2.0 ** -150))


def test_every_patch_played_has_a_control_set():
    assert sorted(CONTROL) == PATCHES and set(INTO) <= set(PATCHES)


@pytest.mark.parametrize("name", PATCHES)
def test_lv2info_lists_the_ports_the_export_made(name, bundles):
    bundle = bundles(name)
    lowered = export_c(hapticgraph.load(bundle.patch), name)
    expected = [("Input", "Audio" if p.kind == "audio" else "CV", p.name) for p in lowered.inputs]
    expected += [("Output", "Audio" if p.kind == "audio" else "CV", p.name) for p in lowered.outputs]
    expected += [("Input", "Control", p.name) for p in lowered.params if p.slot >= 0]
    info = bundle.lilv("lv2info")
    ports = re.findall(r"\tPort (\d+):\n(.*?)(?=\n\tPort |\Z)", info, re.S)
    listed = []
    for index, text in ports:
        kinds = re.findall(r"lv2core#(\w+)Port", text)
        direction = "Input" if "Input" in kinds else "Output"
        kind = next(k for k in kinds if k not in ("Input", "Output"))
        listed.append((direction, kind, re.search(r"Name:\s+(\S+)", text).group(1)))
        # a host without CV leaves a device's column unconnected: the plugin says it may
        assert ("connectionOptional" in text) == (kind == "CV")
    assert [int(i) for i, _ in ports] == list(range(len(expected)))
    assert listed == expected
    assert sum(kind == "Audio" and d == "Input" for d, kind, _ in listed) == 1      # the input added here


@pytest.mark.parametrize("name", PATCHES)
def test_lv2apply_gives_the_python_render_rounded_to_float32(name, bundles):
    bundle = bundles(name)
    got = bundle.apply()
    expected = bundle.render()
    assert np.abs(expected).max() > 1e-3                 # it sounds
    _same_float32(got, expected)


@pytest.mark.parametrize("name", PATCHES)
def test_a_control_set_by_lv2apply_is_run_with_set(name, bundles):
    bundle = bundles(name)
    param, value = CONTROL[name]
    got = bundle.apply([(param.replace(".", "_"), value)])
    # a control port is a float: the plugin sets the parameter to that float's value
    expected = bundle.render([f"{param}={float(np.float32(value))!r}"])
    _same_float32(got, expected)
    assert not np.array_equal(got, bundle.apply())       # the control changed the sound
