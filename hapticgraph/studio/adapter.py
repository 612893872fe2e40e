"""The one place the studio touches the engine: open a session, read a body's cell positions,
find which changes of a patch are live parameters, and carry state over to an edited patch.

Built on hapticgraph.graph.engine.Session and graph.program.Program (what `play` runs); the
public hapticgraph.Session (docs/api.md) offers the same operations.
"""
import numpy as np

from ..devices import DeviceError, audio, open_drivers
from ..devices.kinds import same
from ..graph.program import PlanError
from .describe import alive, bodies

__all__ = ["PlanError", "open_session", "positions", "live_changes", "check_live", "apply_live", "carry",
           "probe_columns", "drivers_for"]


def open_session(patch, drivers, blocksize, probes=()):
    """A play session (compiled kernel, the safety guard of `play`) of `patch`."""
    return audio.play_session(patch, drivers, blocksize, probes=list(probes))


def positions(session, name):
    """A view (no copy) of the positions of every cell of body `name`, flat in C order."""
    return session.prog.state_views(name)[-2]


def probe_columns(session, probes):
    """{probe: its record column}: the probes follow the audio channels, in the order given."""
    base = session.prog.channels
    return {p: base + i for i, p in enumerate(probes)}


def _structure(patch):
    return (patch.rate, sorted(patch.blocks), [type(b.cls) for b in patch.blocks.values()],
            [str(c) for c in patch.connections], sorted(patch.devices))


def live_changes(old, new):
    """[(block, param, value)] if `new` differs from `old` only in live numeric parameters
    (set while playing, state kept), else None (the new patch must be swapped in)."""
    if _structure(old) != _structure(new) or dict(old.devices) != dict(new.devices):
        return None
    changes = []
    for name, inst in new.blocks.items():
        was = old.blocks[name]
        if was.cls is not inst.cls:
            return None
        for key, value in inst.values.items():
            if same(was.values.get(key), value):
                continue
            param = inst.cls.params.get(key)
            if param is None or not param.live or not isinstance(value, (int, float)):
                return None
            changes.append((name, key, float(value)))
    return changes


def check_live(session, changes):
    """PlanError if the running program refuses one of `changes` (e.g. a driven parameter)."""
    for block, param, value in changes:
        session.prog.check_set(block, param, value)


def apply_live(session, changes):
    """Queue the changes: they land at the next block boundary."""
    for block, param, value in changes:
        session.edit(session.prog.set_param, block, param, value)


class _Remap:
    """The cells of an old body's array placed where the new body keeps them (cut cells differ):
    read when the swap copies it (np.copyto calls __array__), so it is the state at the swap."""

    def __init__(self, view, old_alive, new_alive, size):
        self.view, self.old_alive, self.new_alive, self.size = view, old_alive, new_alive, size

    def __array__(self, dtype=None, copy=None):
        full = np.zeros(self.size)
        full[self.old_alive] = self.view
        return full[self.new_alive]


def _at_rest(shape, values, where):
    """Positions in the body's array of its locked cells."""
    compact = np.full(int(np.prod(shape)), -1)
    compact[where] = np.arange(len(where))
    locked = list(values.get("lock", ())) + [c["index"] for c in values.get("cells", ()) if c.get("locked")]
    out = []
    for ix in locked:
        if len(ix) == len(shape):
            k = compact[np.ravel_multi_index(tuple(int(i) for i in ix), shape)]
            if k >= 0:
                out.append(int(k))
    return out


def carry(old, new):
    """(dst, src) pairs giving `new` the state of `old` (copied at the swap): what `play --watch`
    keeps (unchanged blocks), and in the studio also the cells of every body whose shape did not
    change although its parameters did (a lock, a cut, a new tension keep the body moving); its
    locked cells then start at rest."""
    pairs, kept = audio.carry_state(old.prog, new.prog)
    kept = set(kept)
    old_bodies = dict(bodies(old.prog.patch))
    for name, shape in bodies(new.prog.patch):
        if name in kept or old_bodies.get(name) != shape:
            continue
        was, now = old.prog.patch.blocks[name], new.prog.patch.blocks[name]
        if was.cls is not now.cls:
            continue
        old_where, new_where = alive(shape, was.values), alive(shape, now.values)
        vo, vn = old.prog.state_views(name)[-2:], new.prog.state_views(name)[-2:]
        if [len(v) for v in vo] != [len(old_where)] * 2 or [len(v) for v in vn] != [len(new_where)] * 2:
            continue
        size = int(np.prod(shape))
        pairs += [(b, a if np.array_equal(old_where, new_where) else _Remap(a, old_where, new_where, size))
                  for a, b in zip(vo, vn)]
        zero = np.zeros(1)
        pairs += [(v[k:k + 1], zero) for k in _at_rest(shape, now.values, new_where) for v in vn]
    return pairs


def drivers_for(old_session, new_patch, choices):
    """(drivers, opened, unused) for `new_patch`: the running drivers of unchanged devices kept.
    When keeping some cannot work (a block played by a kept controller changed: reload_drivers
    opens the block without its device), every driver is opened afresh."""
    try:
        return audio.reload_drivers(old_session.prog.patch, new_patch, old_session.prog.drivers, choices,
                                    live_input=audio.LiveInput.for_block)
    except DeviceError:
        opened = open_drivers(new_patch, choices, live_input=audio.LiveInput.for_block)
        return opened, opened, list(old_session.prog.drivers.values())
