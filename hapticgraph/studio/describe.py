"""What the page draws and offers, from a loaded patch: its lattices (bodies), joins,
excitations, microphones, the wiring graph and every numeric parameter's declaration (the
`hello` / `describe` object of docs/studio.md)."""
import math

from ..blocks.massspring.checks import STABILITY_BOUND
from . import yamltext as yt
from .edits import cell_text, plain

BODY_TYPES = ("lattice", "cell")
LOG_DECADES = 2.0          # a range spanning this many decades above zero gets a log control


def bodies(patch):
    """The mass-spring bodies cell frames are sent for, in patch order: [(name, shape)]; a
    `cell` block is a lattice of shape [1]."""
    out = []
    for name, inst in patch.blocks.items():
        if inst.cls.type_name == "lattice":
            out.append((name, tuple(int(n) for n in inst.values["shape"])))
        elif inst.cls.type_name == "cell":
            out.append((name, (1,)))
    return out


def _joins(patch):
    """Blocks that link two cells (a `spring`, or any type with cell references `a` and `b`)."""
    out = []
    for name, inst in patch.blocks.items():
        a, b = inst.values.get("a"), inst.values.get("b")
        if isinstance(a, str) and isinstance(b, str) and "a" in inst.cls.params and "b" in inst.cls.params:
            out.append({"block": name, "type": inst.cls.type_name, "a": a, "b": b,
                        "tension": inst.values.get("tension", inst.values.get("k"))})
    return out


def _where(ids, patch, end):
    """cell, lattice id and index of a connection end on a body (None if it is not on one)."""
    if end.block not in ids:
        return {"cell": None, "lattice": None, "index": None}
    return {"cell": cell_text(end.block, end.index), "lattice": ids[end.block],
            "index": list(end.index) if end.index is not None else [0]}


def _players(patch, ids):
    """(excitations, microphones) of docs/studio.md's describe object."""
    mics, excitations = {}, []
    for name, inst in patch.blocks.items():
        if inst.cls.type_name == "mic":
            mics[name] = {"block": name, "cell": None, "lattice": None, "index": None, "port": None,
                          "pan": inst.values.get("pan"), "gain": inst.values.get("gain")}
    for c in patch.connections:
        if c.dst.block in mics and c.dst.port == "in" and c.src.block in ids:
            mics[c.dst.block].update(_where(ids, patch, c.src), port=c.src.port)
        elif c.dst.port == "force" and c.dst.block in ids and c.src.block not in ids:
            inst = patch.blocks[c.src.block]
            excitations.append({"block": c.src.block, "type": inst.cls.type_name, "port": c.src.port,
                                **_where(ids, patch, c.dst)})
    return excitations, list(mics.values())


def _lattice(patch, i, name, shape, overrides):
    inst = patch.blocks[name]
    v = inst.values
    if inst.cls.type_name == "cell":
        locked = [[0]] if v.get("locked") else []
        return {"id": i, "name": name, "type": "cell", "shape": [1], "boundary": None,
                "locked": locked, "cut": [], "cells": []}
    return {"id": i, "name": name, "type": "lattice", "shape": list(shape), "boundary": v.get("boundary"),
            "locked": [list(map(int, ix)) for ix in v.get("lock", [])] + [
                list(c["index"]) for c in overrides if c.get("locked")],
            "cut": [list(map(int, ix)) for ix in v.get("cut", [])],
            "cells": overrides}


def stable_bounds(patch, name, rate):
    """(largest stable tension, smallest stable mass) of a lattice, the others as they are:
    each cell's Σk (2·dim neighbour springs or anchors, and the joins on it) must keep
    dt²·Σk/m + dt·γ/m below the half-step scheme's bound."""
    inst = patch.blocks[name]
    v = inst.values
    dt, dim = 1.0 / rate, len(v["shape"])
    mass, damping, tension = float(v["mass"]), float(v["damping"]), float(v["tension"])
    joins = {}
    for j in _joins(patch):
        for end in (j["a"], j["b"]):
            if end.startswith(name + "[") and isinstance(j["tension"], (int, float)):
                joins[end.replace(" ", "")] = joins.get(end.replace(" ", ""), 0.0) + float(j["tension"])
    cases = [(mass, damping, 0.0)] + [(mass, damping, k) for k in joins.values()]
    cases += [(float(c.get("mass", mass)), float(c.get("damping", damping)), 0.0) for c in v.get("cells", [])]
    t_max = min((STABILITY_BOUND - dt * g / m) * m / (dt * dt) - kj for m, g, kj in cases) / (2 * dim)
    k_max = 2 * dim * tension + max([0.0] + list(joins.values()))
    m_min = (dt * dt * k_max + dt * damping) / STABILITY_BOUND
    return max(t_max, 0.0), m_min


def _param(inst, name, param, value, driven, bounds):
    lo = param.minimum if param.minimum is not None else param.above
    hi = param.maximum if param.maximum is not None else param.below
    log = bool(lo is not None and hi is not None and hi > 0 and lo >= 0
               and (lo == 0 or math.log10(hi / lo) >= LOG_DECADES))
    entry = {"block": inst.name, "param": name, "type": inst.cls.type_name, "value": value,
             "unit": param.unit, "live": param.live, "driven": driven, "min": lo, "max": hi,
             "exclusive_min": param.minimum is None and param.above is not None,
             "exclusive_max": param.maximum is None and param.below is not None,
             "log": log, "stable_max": None, "stable_min": None, "doc": param.doc}
    if bounds is not None and name == "tension":
        entry["stable_max"] = bounds[0]
    if bounds is not None and name == "mass":
        entry["stable_min"] = bounds[1]
    return entry


def params(patch):
    """Every numeric parameter of every block, with its declaration (docs/studio.md)."""
    driven = {(c.dst.block, c.dst.port) for c in patch.connections}
    out = []
    for name, inst in patch.blocks.items():
        bounds = stable_bounds(patch, name, patch.rate) if inst.cls.type_name == "lattice" else None
        for pname, param in inst.cls.params.items():
            value = inst.values.get(pname)
            if param.internal or param.kind != "number" or not isinstance(value, (int, float)):
                continue
            out.append(_param(inst, pname, param, value, (name, pname) in driven, bounds))
    return out


def graph(patch):
    return {"blocks": [{"name": n, "type": b.cls.type_name, "inputs": [p.name for p in b.inputs],
                        "outputs": [p.name for p in b.outputs]} for n, b in patch.blocks.items()],
            "connections": [{"src": str(c.src), "dst": str(c.dst)} for c in patch.connections]}


def describe(patch, text):
    """The describe object (without the studio's own fields: audio, fps, dirty, undo, ...)."""
    root = yt.compose(text)
    ids = {name: i for i, (name, _) in enumerate(bodies(patch))}
    lattices = []
    for i, (name, shape) in enumerate(bodies(patch)):
        overrides = plain(yt.find(root, ("blocks", name, "cells"))) or []
        lattices.append(_lattice(patch, i, name, shape, overrides if isinstance(overrides, list) else []))
    excitations, mics = _players(patch, ids)
    entries = plain(yt.find(root, ("map",))) or []
    return {"patch": {"path": patch.file, "name": patch.name, "rate": patch.rate},
            "lattices": lattices, "joins": _joins(patch), "excitations": excitations, "microphones": mics,
            "graph": graph(patch), "params": params(patch), "map": entries, "text": text}
