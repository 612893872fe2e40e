"""The studio's commands (docs/studio.md): each takes the StudioSession, the command object and
the connection's view settings, and returns the reply's `result` or raises CommandError."""
import math

import numpy as np

from ..graph.modes import BudgetError, mode_shape, network_modes
from . import edits
from .edits import EditError, parse_cell
from .session import CommandError
from .yamltext import TextError

MAX_MODES = 200
MAX_PROBES = 32            # signals streamed at once (each is a column the sound computes and sends)


class View:
    """What one connection receives: cell frames at most `fps` a second, of `lattices` (None: all)."""

    def __init__(self, fps):
        self.fps, self.lattices, self.top = fps, None, fps


def _field(msg, name, kinds, default=...):
    value = msg.get(name, default)
    if value is ...:
        raise CommandError([f"studio: {msg.get('cmd')}: missing field {name!r}"])
    if value is None and default is None:
        return None
    if not isinstance(value, kinds) or isinstance(value, bool) and bool not in kinds:
        raise CommandError([f"studio: {msg.get('cmd')}: {name!r} has the wrong type ({type(value).__name__})"])
    return value


def _number(msg, name, default=...):
    value = _field(msg, name, (int, float), default)
    if value is not None and not math.isfinite(value):
        raise CommandError([f"studio: {msg.get('cmd')}: {name!r} must be a finite number"])
    return value


def _edit(st, msg, block, make, gesture=None):
    """Run the text edit `make(text)`; the new text through the loader to the sound."""
    try:
        text = make(st.text)
    except (EditError, TextError) as exc:
        raise CommandError([st.where(block, str(exc))]) from None
    st.change(text, msg["cmd"], block, gesture=gesture)


def _set(st, msg, view):
    block, param = _field(msg, "block", str), _field(msg, "param", str)
    value = _field(msg, "value", (int, float, str, list, bool))
    gesture = _field(msg, "gesture", (str, int), None)      # one slider drag: one undo entry
    if isinstance(value, float) and not math.isfinite(value):
        raise CommandError(["studio: set: the value must be a finite number"])
    _edit(st, msg, block, lambda t: edits.set_param(t, st.patch, block, param, value),
          gesture=None if gesture is None else (block, param, gesture))
    return {"value": value}


def _cells_of(msg):
    cells = msg.get("cells", [msg.get("cell")] if "cell" in msg else None)
    if not isinstance(cells, list) or not cells or not all(isinstance(c, str) for c in cells):
        raise CommandError([f"studio: {msg['cmd']}: give `cell` (\"plate[4, 5]\") or `cells` (a list of them)"])
    return cells


def _cell_edit(st, msg, view):
    cells = _cells_of(msg)

    def make(text):
        for cell in cells:
            text = edits.cell_edit(text, st.patch, msg["cmd"], cell)
        return text
    _edit(st, msg, _block_of(cells[0]), make)
    return {}


def _block_of(cell):
    try:
        return parse_cell(cell)[0]
    except EditError:
        return None


def _cells(st, msg, view):
    block = _field(msg, "block", str)
    indices = _field(msg, "cells", list)
    values = {k: msg[k] for k in ("mass", "damping") if k in msg}
    if not values:
        raise CommandError(["studio: cells: give `mass` and/or `damping` (null removes the override)"])
    for k, v in values.items():
        if v is not None:
            _number(msg, k)
    _edit(st, msg, block, lambda t: edits.cells(t, st.patch, block, indices, values))
    return {}


def _join(st, msg, view):
    a, b = _field(msg, "a", str), _field(msg, "b", str)
    tension, name = _number(msg, "tension", None), _field(msg, "block", str, None)
    made = {}

    def make(text):
        text, made["block"] = edits.join(text, st.patch, a, b, tension, name)
        return text
    _edit(st, msg, _block_of(a), make)
    return {"block": made["block"]}


def _place(st, msg, view):
    block, cell = _field(msg, "block", str), _field(msg, "cell", str)
    port, kind = _field(msg, "port", str, None), _field(msg, "type", str, None)
    params = _field(msg, "params", dict, None)
    _edit(st, msg, block, lambda t: edits.place(t, st.patch, block, cell, port, kind, params))
    return {"block": block, "cell": cell}


def _remove(st, msg, view):
    block = _field(msg, "block", str)
    _edit(st, msg, block, lambda t: edits.remove(t, st.patch, block))
    return {}


def _map(st, msg, view):
    entries = _field(msg, "entries", list)
    _edit(st, msg, None, lambda t: edits.write_map(t, entries))
    return {}


def _text(st, msg, view):
    st.change(_field(msg, "text", str), "text")
    return {}


def _state(st, msg, view):
    return {"text": st.text, "path": st.path, "dirty": st.text != st.saved, "problem": st.problem,
            "undo": len(st.undo_stack), "redo": len(st.redo_stack), "t": st.live.t / st.live.rate,
            "recovery": None if st.offer is None else st.offer.event()}


def _modes(st, msg, view):
    count = _field(msg, "count", int, 10)
    if not 1 <= count <= MAX_MODES:
        raise CommandError([f"studio: modes: count must be 1 … {MAX_MODES}"])
    try:
        return {"networks": [m.as_dict() for m in network_modes(st.patch, count)]}
    except BudgetError as exc:             # more modes than fit in memory: the largest count that does
        raise CommandError([f"studio: modes: {exc}"]) from None


def _mode_shape(st, msg, view):
    lattice, mode = _field(msg, "lattice", str), _field(msg, "mode", int)
    try:
        freq, shape = mode_shape(st.patch, lattice, mode)
    except ValueError as exc:
        raise CommandError([st.where(lattice, str(exc))]) from None
    flat = np.asarray(shape, dtype=float).ravel()
    return {"lattice": lattice, "mode": mode, "frequency": float(freq), "shape": list(np.shape(shape)) or [1],
            "values": [None if math.isnan(v) else float(v) for v in flat]}


def _probe(st, msg, view):
    signal = _field(msg, "signal", str).strip()
    if signal not in st.probes:
        if len(st.probes) >= MAX_PROBES:
            raise CommandError([f"studio: probe: {MAX_PROBES} signals are probed already (unprobe one first)"])
        st.probes[signal] = max(st.probes.values(), default=0) + 1
        try:
            st.swap(st.patch, probes=list(st.probes))
        except (st.PlanError, ValueError) as exc:
            del st.probes[signal]
            raise CommandError([st.where(signal.split("[")[0].split(".")[0], str(exc))]) from None
        except BaseException:
            del st.probes[signal]          # whatever stopped the swap, the probes are as they were
            raise
        st.tap.set_probes(st.probes)
    return {"probe": st.probes[signal], "signal": signal, "rate": st.patch.rate}


def _unprobe(st, msg, view):
    ident = _field(msg, "probe", int)
    for signal, i in list(st.probes.items()):
        if i == ident:
            del st.probes[signal]
            st.tap.set_probes(st.probes)
            st.swap(st.patch, probes=list(st.probes))
            return {}
    raise CommandError([f"studio: unprobe: no probe {ident}"])


def _frames(st, msg, view):
    fps = _number(msg, "fps")
    lattices = _field(msg, "lattices", list, None)
    view.fps = max(0.0, min(float(fps), view.top))
    view.lattices = None if lattices is None else {int(i) for i in lattices}
    return {"fps": view.fps}


def _restart(st, msg, view):
    st.restart()
    return {}


COMMANDS = {
    "describe": lambda st, msg, view: st.describe(),
    "state": _state,
    "diff": lambda st, msg, view: {"diff": st.diff()},
    "save": lambda st, msg, view: st.save(_field(msg, "path", str, None)),
    "undo": lambda st, msg, view: st.step(True),
    "redo": lambda st, msg, view: st.step(False),
    "set": _set, "lock": _cell_edit, "unlock": _cell_edit, "cut": _cell_edit, "cells": _cells,
    "join": _join, "place": _place, "remove": _remove, "map": _map, "text": _text,
    "modes": _modes, "mode_shape": _mode_shape, "probe": _probe, "unprobe": _unprobe,
    "frames": _frames, "restart": _restart,
    "recover": lambda st, msg, view: st.recover(),
    "discard_recovery": lambda st, msg, view: st.discard_recovery(),
}


def _shown(value, most=60):
    """A value a client sent, as an error message quotes it: its repr, cut at `most` characters."""
    text = repr(value) if isinstance(value, (str, int, float, bool, type(None))) else f"a {type(value).__name__}"
    return text if len(text) <= most else text[:most] + "…"


def handle(st, msg, view):
    """The reply to one command object (docs/studio.md)."""
    cmd = msg.get("cmd") if isinstance(msg, dict) else None
    reply = {"type": "reply", "id": msg.get("id") if isinstance(msg, dict) else None,
             "cmd": cmd if isinstance(cmd, str) else None}
    try:
        fn = COMMANDS.get(cmd) if isinstance(cmd, str) else None
        if fn is None:
            raise CommandError([f"studio: unknown command {_shown(cmd)} (one of {', '.join(sorted(COMMANDS))})"])
        with st.lock:
            result = fn(st, msg, view)
        return {**reply, "ok": True, "result": result}
    except CommandError as exc:
        return {**reply, "ok": False, "error": exc.errors[0], "errors": exc.errors}
    except Exception as exc:  # noqa: BLE001 - a device that will not open, a full disk: said, not fatal
        text = f"studio: {exc}" if isinstance(exc, st.PlanError) else f"studio: {type(exc).__name__}: {exc}"
        return {**reply, "ok": False, "error": text, "errors": [text]}
