"""Issue 21 item 5: a block named without its port (`--probe tip`, `--set tip=3`, the console's
`set tip 3`) is told which ports (or parameters) the block has, with the usual did-you-mean for a
name that is no block."""
import io

from project_env import EDITABLE_STRING
from hostile_env import assert_patch_error

import hapticgraph
from hapticgraph.console import Console

PATCH = """hapticgraph: 1
rate: 8000
blocks:
  tone: {type: wavetable, shape: sine, frequency: 100.0, amplitude: 0.25}
  amp: {type: gain, gain: 0.5}
  out: {type: audio_out, channels: 1}
connect:
  - tone.out -> amp.in
  - amp.out -> out.ch0
"""


def test_probe_of_a_block_lists_its_ports(hg, write_patch):
    path = write_patch(PATCH)
    proc = hg("run", path, "--seconds", 0.01, "--probe", "amp", "--out", path.with_suffix(".wav"))
    assert_patch_error(proc, "probe 'amp'")
    assert "block 'amp' (gain) has: out, in, gain" in proc.stderr, proc.stderr
    proc = hg("run", path, "--seconds", 0.01, "--probe", "ampp", "--out", path.with_suffix(".wav"))
    assert_patch_error(proc, "no block named 'ampp' (did you mean 'amp'?)")


def test_set_of_a_block_lists_its_parameters(hg, write_patch):
    path = write_patch(PATCH)
    proc = hg("check", path, "--set", "tone=3")
    assert_patch_error(proc, "--set 'tone=3'")
    assert "block 'tone' (wavetable) has the parameters: " in proc.stderr, proc.stderr
    assert "frequency" in proc.stderr and "amplitude" in proc.stderr
    proc = hg("check", path, "--set", "tonne=3")
    assert_patch_error(proc, "no block named 'tonne' (did you mean 'tone'?)")


def test_console_set_of_a_block_lists_its_live_parameters(write_patch):
    s = hapticgraph.Session.open(write_patch(EDITABLE_STRING), blocksize=64)
    out = io.StringIO()
    Console(lambda: s, stream=io.StringIO("set mic 0.5\nset mik.gain 1\nset mic.gian 1\n"), out=out).run()
    text = out.getvalue().splitlines()
    assert "block 'mic' (mic) has the live parameters: gain, pan" in text[0], text
    assert "no block named 'mik' (did you mean 'mic'?)" in text[1], text
    assert "(did you mean 'gain'?)" in text[2] and "gain, pan" in text[2], text
