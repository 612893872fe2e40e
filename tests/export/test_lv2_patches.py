"""Every shipped patch as an LV2 plugin in Debian's lilv tools: `lv2info` loads it and lists its
ports as the export made them, and `lv2apply` runs it over a WAV file to hapticgraph's samples
rounded to float32 (LV2 carries float32; the plugin computes in double), with its controls at
their defaults and with one set by `-c SYMBOL VALUE` (as `run --set` sets it).

What lv2apply (lilv 0.24, tools/lv2apply.c) does with a plugin: it refuses one without an audio
input ("Unable to map 1 inputs to 0 ports") and one with a port neither audio nor control unless
that port is lv2:connectionOptional ("Port N has unsupported type"); it reads the file's rate and
runs one frame per call, each audio port on the file, each control port on one float (its
default, or the `-c` value). An optional port of another kind is left typed as a control port (the
port's type starts as 0, TYPE_CONTROL, and nothing changes it): a CV port is connected to one
float too, so `-c` holds a device's column at a constant, and a force is written there and lost.

No shipped patch has an audio input, so each is played here with one added (`lv2apply_in`, fed
from the WAV file); it is left unconnected, so the patch sounds as shipped, except where the
device held still leaves the instrument silent (a finger plucks only when it moves): there the
WAV goes into the string (INTO). Each device column is held by `-c` at a constant (HELD), which
the Python render feeds too (Held, as float32 rounds it); the forces are not compared. The MIDI
patches (midi_melody, poly_strings) are not played: their MIDI input is being redone as an LV2
atom port."""
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
# where the WAV file goes in a patch whose finger held still plucks nothing: a string's first delay
INTO = {"buzz_50hz": "r1.in", "fig8_pluck_damp": "r1.in", "plucked_string": "r1.in"}
# each device column held by lv2apply's -c: a finger near or on the string, a bow moving, a
# trigger and pedals pressed, joysticks off centre
HELD = {
    "babe_is_sleeping": {"stick.sensor_x": 0.001, "stick.sensor_v": 0.01, "stick.jx": 0.3, "stick.jy": -0.3,
                         "pedals.sensor_x": 0.002, "pedals.sensor_v": -0.01, "pedals.swell": 0.5},
    "buzz_50hz": {"finger.sensor_x": 1e-5, "finger.sensor_v": 0.01, "finger.grip": 0.3},
    "fig7_bowed_string": {"arm.sensor_x": 0.01, "arm.sensor_v": 0.2},
    "fig8_pluck_damp": {"finger.sensor_x": 1e-5, "finger.sensor_v": 0.01, "finger.grip": 0.3},
    "force_feedback_mic": {"joy.sensor_x": 0.001, "joy.sensor_v": 0.01, "joy.fire": 1.0, "joy.slider": 0.5},
    "plucked_string": {"finger.sensor_x": 0.0002, "finger.sensor_v": 0.01},
    "string_bound_explicit": {"finger.sensor_x": 0.001, "finger.sensor_v": 0.01},
    "string_bound_implicit": {"finger.sensor_x": 0.001, "finger.sensor_v": 0.01},
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


def _symbol(name):
    """The LV2 symbol of a port or parameter named BLOCK.NAME (hapticgraph.export.lv2)."""
    return name.replace(".", "_")


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
        text["blocks"][INPUT] = {"type": "audio_in", "file": "input.wav", "gain": 0.5}
        if name in INTO:
            text["connect"].append(f"{INPUT}.out -> {INTO[name]}")
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

    def apply(self, held, sets=()):
        """lv2apply's output over the WAV file (frames × channels, float32 values as float64), the
        device columns `held` ({"DEVICE.COLUMN": value}) and the parameters `sets` ((BLOCK.PARAM, value)
        pairs) given by -c."""
        out = self.folder / "out.wav"
        args = ["-i", str(self.folder / "input.wav"), "-o", str(out)]
        for name, value in [*held.items(), *sets]:
            args += ["-c", _symbol(name), repr(value)]
        self.lilv("lv2apply", *args)
        got, rate = soundfile.read(out, dtype="float64", always_2d=True)
        assert rate == self.rate and soundfile.info(out).subtype == "FLOAT"
        return got

    def render(self, held, sets=()):
        """The Python render of the same patch: the device columns held as lv2apply holds them (a
        control port is a float), the WAV file in, the parameters set as `run --set` sets them."""
        patch = hapticgraph.load(self.patch, overrides=[f"{name}={float(np.float32(v))!r}" for name, v in sets])
        drivers = {}
        for device, driver in column_drivers(patch).items():
            row = [np.float32(held.get(f"{device}.{column}", 0.0)) for column in driver.columns]
            values = np.tile(np.array(row, dtype=np.float64), (len(self.wav), 1))
            if device == INPUT:
                values[:, 0] = self.wav
            drivers[device] = Held(driver, values)
        return hapticgraph.render(patch, SECONDS, drivers=drivers).audio


def _same_float32(got, expected):
    """lv2apply's samples are the double render rounded once to float32: within half an ulp, 2**-24
    relative, or 2**-150 absolute among float32's subnormals (a lattice's wave front is that small)."""
    assert got.shape == expected.shape
    assert np.array_equal(got, expected.astype(np.float32).astype(np.float64))
    assert np.all(np.abs(got - expected) <= np.maximum(np.abs(expected) * 2.0 ** -24, 2.0 ** -150))


def _lists_the_ports_the_export_made(bundle):
    lowered = export_c(hapticgraph.load(bundle.patch), bundle.name)
    expected = [("Input", "Audio" if p.kind == "audio" else "CV", p.name) for p in lowered.inputs]
    expected += [("Output", "Audio" if p.kind == "audio" else "CV", p.name) for p in lowered.outputs]
    expected += [("Input", "Control", p.name) for p in lowered.params if p.slot >= 0]
    info = bundle.lilv("lv2info")
    ports = re.findall(r"\tPort (\d+):\n(.*?)(?=\n\tPort |\Z)", info, re.S)
    listed = []
    for _, text in ports:
        kinds = re.findall(r"lv2core#(\w+)Port", text)
        direction = "Input" if "Input" in kinds else "Output"
        kind = next(k for k in kinds if k not in ("Input", "Output"))
        listed.append((direction, kind, re.search(r"Name:\s+(\S+)", text).group(1)))
        # a host without CV may leave a device's column unconnected: the plugin says it may
        assert ("connectionOptional" in text) == (kind == "CV")
    assert [int(i) for i, _ in ports] == list(range(len(expected)))
    assert listed == expected
    assert sum(kind == "Audio" and d == "Input" for d, kind, _ in listed) == 1      # the input added here
    assert sorted(HELD.get(bundle.name, {})) == sorted(p.name for p in lowered.inputs if p.kind == "cv")


def _plays_the_python_render(bundle, held):
    got = bundle.apply(held)
    expected = bundle.render(held)
    assert np.abs(expected).max() > 1e-2                 # it sounds
    _same_float32(got, expected)
    if held:
        assert not np.array_equal(got, bundle.apply({}))  # what -c holds reaches the plugin
    return got


def _takes_a_control_as_run_set_sets_it(bundle, held, plain):
    sets = [CONTROL[bundle.name]]
    got = bundle.apply(held, sets)
    _same_float32(got, bundle.render(held, sets))
    assert not np.array_equal(got, plain)                # the control changed the sound


@pytest.mark.parametrize("name", PATCHES)
def test_lv2info_lists_it_and_lv2apply_plays_it_as_hapticgraph_does(name, tmp_path):
    # one test a patch: one worker builds its bundle and compiles its kernel
    bundle = Bundle(name, tmp_path)
    held = HELD.get(name, {})
    _lists_the_ports_the_export_made(bundle)
    plain = _plays_the_python_render(bundle, held)
    _takes_a_control_as_run_set_sets_it(bundle, held, plain)


def test_every_patch_played_is_named_here():
    assert sorted(CONTROL) == PATCHES and set(INTO) <= set(HELD) <= set(PATCHES)
