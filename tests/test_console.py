"""Edits typed while playing (`play --console`): checked, queued, applied at a block boundary."""
import io

import numpy as np

import hapticgraph
from project_env import EDITABLE_STRING
from hapticgraph.console import Console, submit


def session(write_patch, editable=True):
    return hapticgraph.Session.open(write_patch(EDITABLE_STRING), blocksize=256, editable=editable)


def test_commands_apply_at_the_next_block(write_patch):
    s = session(write_patch)
    out = io.StringIO()
    console = Console(lambda: s, stream=io.StringIO("set mic.gain 0\nlock str[20]\ncut str[30]\n"), out=out)
    console.run()                     # read every line (the thread's body), queue the edits
    assert s.params("mic")["gain"] == 1.0 and s.pending == 3    # nothing applied yet
    s.process(256)
    assert console.applied == ["mic.gain = 0", "lock str[20]", "cut str[30]"]
    cells = s.points("str")
    assert cells.locked[20] and cells.cut[30] and not cells.locked[30]
    assert np.all(s.process(256)[:, 0] == 0.0)


def test_mistakes_change_nothing(write_patch):
    s = session(write_patch)
    out = io.StringIO()
    console = Console(lambda: s, stream=io.StringIO(
        "set mic.nope 1\nset mic.pan 3\nset nobody.gain 1\nlock str[99]\nfrobnicate\nset hit.force x\n"), out=out)
    console.run()
    s.process(256)
    assert console.applied == [] and s.pending == 0
    text = out.getvalue()
    for needle in ("mic.nope is not a live parameter", "outside the range of mic.pan", "no block named 'nobody'",
                   "out of range", "unknown command 'frobnicate'", "'x' is not a number"):
        assert needle in text


def test_stencil_sessions_refuse_cell_edits(write_patch):
    s = session(write_patch, editable=False)
    try:
        submit("lock str[3]", s)
    except ValueError as exc:
        assert "stencil" in str(exc)
    else:
        raise AssertionError("a stencil network accepted a cell edit")
