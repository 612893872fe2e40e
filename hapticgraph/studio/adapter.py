"""The one place the studio touches the engine, through the public hapticgraph.Session
(docs/api.md): open a session, read a body's cells, find which changes of a patch are live
parameters, and swap an edited patch in keeping state.

`Live` holds the running Session for the sound's thread (the clock runner's, or the sound card's
callback through devices.audio.Player, which sees it as it sees play's session): each block is
processed under its lock, so the studio can hand a swap extra state between two blocks.
"""
import threading

import numpy as np

from ..devices import audio
from ..devices.driver_kind import same
from ..graph.program import PlanError
from ..session import Session
from .describe import bodies

__all__ = ["Live", "PlanError", "open_session", "cells_of", "live_changes", "apply_live", "swap", "restart"]


def open_session(patch, blocksize, devices=None, drivers=None, probes=()):
    """A Session of `patch` (compiled kernel, play's safety guard; lattices on their fast path:
    lock and cut reach the sound by a swap)."""
    return Session.open(patch, probes=list(probes), devices=devices, drivers=drivers, blocksize=blocksize,
                        editable=False, live_input=audio.LiveInput.for_block)


class Live:
    """The running Session as devices.audio.Player and the clock runner use it."""

    def __init__(self, session):
        self.session = session
        self.lock = threading.Lock()

    def __getattr__(self, name):
        # what else the Player reads of a Session (channels, probes, drivers, swaps, pending,
        # apply, inputs, program): the one playing now (a restart replaces it)
        return getattr(self.session, name)

    @property
    def rate(self):
        return self.session.rate

    @property
    def blocksize(self):
        return self.session.blocksize

    @property
    def t(self):
        return self.session.t

    @property
    def prog(self):
        return self.session.program

    def process(self, n):
        with self.lock:
            return self.session.process(n)

    def start(self):
        self.session.start()

    def stop(self):
        """The Player's end of a run: the studio closes the session itself when it ends."""

    def replace(self, session):
        """Play `session` from the next block on (a restart): the old one stops its drivers,
        which the new one (given the same) starts again at its first block."""
        with self.lock:
            old, self.session = self.session, session
            old.close()


def cells_of(session, name):
    """(view of the positions of body `name` — not always contiguous: flatten it when read —,
    full-shape C-order index of each entry or None when the body has all its cells)."""
    pts = session.points(name)
    view = pts.positions
    shape = tuple(pts.shape) or (1,)
    if view.size == int(np.prod(shape)):
        return view, None
    cells = np.asarray(pts.cells).reshape(view.size, -1)
    return view, np.ravel_multi_index(tuple(cells.T), shape)


def _structure(patch):
    return (patch.rate, sorted(patch.blocks), [type(b.cls) for b in patch.blocks.values()],
            [str(c) for c in patch.connections], sorted(patch.devices))


def live_changes(old, new):
    """[(block, param, value)] if `new` differs from `old` only in live numeric parameters
    (set while playing, state kept), else None (the new patch must be swapped in)."""
    if _structure(old) != _structure(new) or not same(dict(old.devices), dict(new.devices)):
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


def apply_live(session, changes):
    """Queue the changes (they land at the next block boundary); ValueError, and nothing
    queued, if the running patch refuses one of them."""
    for block, param, value in changes:
        try:
            session.program.check_set(block, param, value)
        except PlanError as exc:
            raise ValueError(str(exc)) from None
    for block, param, value in changes:
        session.set(block, param, value)


class _Read:
    """A value read when the swap copies it (np.copyto calls __array__): the state at the swap."""

    def __init__(self, read):
        self.read = read

    def __array__(self, dtype=None, copy=None):
        return self.read()


def _motion(pts, rate, which):
    """The cells' positions (which 0), velocities (1) or positions one sample before (2) now, flat,
    from what the body's group stores (velocities, or positions one sample before)."""
    x = pts.positions.reshape(-1)
    if which == 0:
        return x
    if pts.previous is None:
        v = pts.velocities.reshape(-1)
        return v if which == 1 else x - v / rate
    p = pts.previous.reshape(-1)
    return (x - p) * rate if which == 1 else p


def _placed(before, rate, which, cells_old, cells_new, size, shape):
    """What the new body's array `which` takes from the old body, read at the swap: the old
    cells placed where the new body keeps them (cut cells differ), shaped `shape`."""
    def read():
        a = _motion(before, rate, which)
        if not np.array_equal(cells_old, cells_new):
            full = np.zeros(size)
            full[cells_old] = a
            a = full[cells_new]
        return a.reshape(shape)
    return _Read(read)


def _cells(prog, name, shape):
    pts = prog.points(name)
    size = int(np.prod(shape))
    if pts.positions.size == size:
        return np.arange(size)
    return np.ravel_multi_index(tuple(np.asarray(pts.cells).reshape(pts.positions.size, -1).T), shape)


def body_carry(old, new, kept):
    """(dst, src) pairs giving the bodies of `new` (a Program) the cells of `old` where
    play --watch would start them at rest: a body whose shape did not change keeps moving
    through a lock, a cut, a new tension or a moved microphone; its locked cells stop."""
    pairs = []
    old_bodies = dict(bodies(old.patch))
    for name, shape in bodies(new.patch):
        if name in kept or old_bodies.get(name) != shape or old.patch.blocks[name].cls is not new.patch.blocks[name].cls:
            continue
        before, after = old.points(name), new.points(name)
        cells_old, cells_new = _cells(old, name, shape), _cells(new, name, shape)
        size = int(np.prod(shape))
        second = (after.velocities, 1) if after.previous is None else (after.previous, 2)
        for dst, which in ((after.positions, 0), second):
            pairs.append((dst, _placed(before, old.rate, which, cells_old, cells_new, size, dst.shape)))
        locked = np.flatnonzero(np.asarray(after.locked).reshape(-1))
        zero = np.zeros(1)
        pairs += [(v.reshape(-1)[k:k + 1], zero) for k in locked for v in (after.positions, after.velocities)]
    return pairs


def swap(live, patch, probes=None):
    """Queue `patch` on the running session (compiled now; the old one plays meanwhile), with
    the studio's body carry added; a Swap (`wait(timeout)`)."""
    session = live.session
    old = session.program
    queued = session.swap(patch, probes=probes)
    extra = body_carry(old, queued.runner.prog, set(queued.kept))
    with live.lock:                 # between two blocks
        if queued.applied.is_set():        # it played already: the old cells are as it left them
            for dst, src in extra:
                np.copyto(dst, src)
        else:
            queued.carry.extend(extra)
    return queued


def restart(live, patch, probes=()):
    """The patch from rest at t = 0, with the running drivers."""
    session = live.session
    fresh = open_session(patch, session.blocksize, drivers=session.drivers, probes=probes)
    live.replace(fresh)
    return fresh
