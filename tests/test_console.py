"""Edits typed while playing (`play --console`): checked, queued, applied at a block boundary."""
import io

import numpy as np

from hapticgraph.console import Console, parse

def session(string_session, editable=True):
    return string_session(256, editable)


def test_commands_apply_at_the_next_block(string_session):
    s = session(string_session)
    out = io.StringIO()
    console = Console(lambda: s, stream=io.StringIO("set mic.gain 0\nlock str[20]\ncut str[30]\n"), out=out)
    console.run()                     # read every line (the thread's body), queue the edits
    assert s.prog.live[s.prog.by_name["mic"].live["gain"]] == 1.0    # nothing applied yet
    s.process(256)
    assert console.applied == ["mic.gain = 0", "lock str[20]", "cut str[30]"]
    net = s.prog.groups[0].group
    assert net.inv_m[20] == 0.0 and net.inv_m[30] == 0.0
    assert np.all(s.process(256)[:, 0] == 0.0)


def test_mistakes_change_nothing(string_session):
    s = session(string_session)
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


def test_stencil_sessions_refuse_cell_edits(string_session):
    s = session(string_session, editable=False)
    try:
        parse("lock str[3]", s.prog)
    except ValueError as exc:
        assert "stencil" in str(exc)
    else:
        raise AssertionError("a stencil network accepted a cell edit")
