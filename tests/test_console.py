"""Edits typed while playing (`play --console`): checked, queued, applied at a block boundary."""
import io

import numpy as np

from hapticgraph import load
from hapticgraph.console import Console, parse
from hapticgraph.devices import open_drivers
from hapticgraph.graph.engine import Session

PATCH = """
hapticgraph: 1
rate: 44100
blocks:
  str: {type: lattice, shape: [41], mass: 0.001, tension: 200000.0}
  hit: {type: pluck, force: 0.5, duration: 0.0005}
  mic: {type: mic}
  out: {type: audio_out, channels: 1}
connect:
  - hit.out -> str[5].force
  - str[12].velocity -> mic.in
  - mic.left -> out.ch0
"""


def session(write_patch, editable=True):
    patch = load(write_patch(PATCH))
    return Session(patch, drivers=open_drivers(patch), blocksize=256, editable=editable)


def test_commands_apply_at_the_next_block(write_patch):
    s = session(write_patch)
    out = io.StringIO()
    console = Console(lambda: s, stream=io.StringIO("set mic.gain 0\nlock str[20]\ncut str[30]\n"), out=out)
    console.run()                     # read every line (the thread's body), queue the edits
    assert s.prog.live[s.prog.by_name["mic"].live["gain"]] == 1.0    # nothing applied yet
    s.process(256)
    assert console.applied == ["mic.gain = 0", "lock str[20]", "cut str[30]"]
    net = s.prog.networks[0].net
    assert net.inv_m[20] == 0.0 and net.inv_m[30] == 0.0
    assert np.all(s.process(256)[:, 0] == 0.0)


def test_mistakes_change_nothing(write_patch):
    s = session(write_patch)
    out = io.StringIO()
    console = Console(lambda: s, stream=io.StringIO(
        "set mic.nope 1\nset mic.pan 3\nset nobody.gain 1\nlock str[99]\nfrobnicate\nset hit.force x\n"), out=out)
    console.run()
    s.process(256)
    assert console.applied == [] and not s.edits
    text = out.getvalue()
    for needle in ("mic.nope is not a live parameter", "outside the range of mic.pan", "no block named 'nobody'",
                   "out of range", "unknown command 'frobnicate'", "'x' is not a number"):
        assert needle in text


def test_stencil_sessions_refuse_cell_edits(write_patch):
    s = session(write_patch, editable=False)
    try:
        parse("lock str[3]", s.prog)
    except ValueError as exc:
        assert "stencil" in str(exc)
    else:
        raise AssertionError("a stencil network accepted a cell edit")
