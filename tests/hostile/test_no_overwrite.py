"""Issue 21 item 4: no command overwrites its input. An output path that resolves to the patch, a
plugin file, a device's profile, an audio_in file or a take the command reads is refused before any
work (exit 2, naming the option), for every subcommand that writes: `run --out/--probes`,
`graph -o`, `plot -o`, `play --record`."""
import os
import shutil

import numpy as np
import pytest
import soundfile

from hostile_env import assert_patch_error

PLUGIN = '''
from hapticgraph.blocks import Block, In, Out, Param


class Twice(Block):
    """out[n] = 2 in[n]."""
    type_name = "twice"
    x = In(name="in")
    y = Out(name="out")

    @staticmethod
    def output(x):
        return 2.0 * x
'''

PATCH = """hapticgraph: 1
rate: 8000
plugins: [twice.py]
devices:
  pad: {driver: hid, profile: pad.yaml}
blocks:
  tone: {type: wavetable, shape: sine, frequency: 100.0, amplitude: 0.25}
  dbl: {type: twice}
  src: {type: audio_in, file: voice.wav}
  out: {type: audio_out, channels: 2}
connect:
  - tone.out -> dbl.in
  - dbl.out -> out.left
  - src.out -> out.right
"""


@pytest.fixture
def folder(tmp_path, patches_dir):
    (tmp_path / "twice.py").write_text(PLUGIN)
    profile = os.path.join(os.path.dirname(patches_dir), "devices", "profiles", "haptic_1dof.yaml")
    shutil.copy(profile, tmp_path / "pad.yaml")
    soundfile.write(tmp_path / "voice.wav", np.zeros(100), 8000)
    (tmp_path / "p.yaml").write_text(PATCH)
    return tmp_path


def _contents(folder):
    return {name: (folder / name).read_bytes() for name in sorted(os.listdir(folder))
            if (folder / name).is_file()}


@pytest.mark.parametrize("command", [
    ["graph", "p.yaml", "-o", "p.yaml"],
    ["graph", "p.yaml", "--format", "mermaid", "-o", "./twice.py"],
    ["graph", "p.yaml", "-o", "pad.yaml"],
    ["graph", "p.yaml", "-o", "link.txt"],
    ["plot", "p.yaml", "--probe", "tone.out", "-o", "p.yaml"],
    ["plot", "p.yaml", "--probe", "tone.out", "-o", "voice.wav"],
    ["run", "p.yaml", "--seconds", "0.01", "--probe", "tone.out", "--probes", "pad.npz"],
])
def test_an_output_naming_an_input_is_refused(hg, folder, command):
    os.symlink(folder / "p.yaml", folder / "link.txt")
    os.symlink(folder / "pad.yaml", folder / "pad.npz")         # the profile under another name
    before = _contents(folder)
    proc = hg(*command, cwd=folder)
    assert_patch_error(proc, "is a file this ")
    option = command[command.index(next(c for c in command if c in ("-o", "--out", "--probes")))]
    assert option in proc.stderr, proc.stderr
    assert _contents(folder) == before


def test_graph_still_writes_elsewhere(hg, folder):
    proc = hg("graph", "p.yaml", "-o", "p.dot", cwd=folder)
    assert proc.returncode == 0, proc.stderr
    assert (folder / "p.dot").read_text().startswith("digraph")


def test_play_record_over_the_take_it_replays_is_refused(hg, folder):
    """`play --replay take.hgrec --record take` would truncate the take while reading it."""
    (folder / "q.yaml").write_text(PATCH.replace("plugins: [twice.py]\n", "").replace(
        "  pad: {driver: hid, profile: pad.yaml}\n", "  pad: {driver: simulated}\n").replace(
        "dbl: {type: twice}", "dbl: {type: gain, gain: 2.0}"))
    (folder / "take.hgrec").write_bytes(b"not really a take, never read: refused first")
    soundfile.write(folder / "take.wav", np.zeros((10, 2)), 8000)
    before = _contents(folder)
    proc = hg("play", "q.yaml", "--replay", "take.hgrec", "--record", "take", cwd=folder)
    assert_patch_error(proc, "--record")
    assert "is a file this " in proc.stderr
    proc = hg("play", "q.yaml", "--record", "voice", cwd=folder)     # voice.wav: the audio_in file
    assert_patch_error(proc, "--record")
    assert "voice.wav" in proc.stderr
    assert _contents(folder) == before
