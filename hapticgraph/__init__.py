"""hapticgraph: physical-model haptic musical instruments, compiled to one single-sample kernel.

    patch = hapticgraph.load("patches/karplus_strong.yaml")
    result = hapticgraph.render(patch, seconds=1.0, probes=["loop.out"])
    result.audio, result.probes["loop.out"], result.rate
"""
import os

from .blocks import Block, Buffer, In, Out, Param, State, helper
from .graph.engine import Render
from .graph.engine import render as _render
from .graph.errors import PatchError, Problem
from .graph.patch import Patch
from .graph.patch import load
from .graph.registry import Registry
from .devices import open_drivers

__version__ = "0.1.0"


def render(patch, seconds=1.0, probes=(), engine="compiled", progress=None, devices=None, drivers=None,
           safety=False, chunk=1 << 14, runaway=1e3):
    """Render a patch (a Patch or a path) offline: `.audio` (frames × channels), `.probes`, `.rate`.

    Devices run on their patch's drivers (the simulated device by default); `devices` maps a
    device name to another driver name, `drivers` to ready Driver objects.
    """
    if isinstance(patch, (str, os.PathLike)):
        patch = load(patch)
    if drivers is None:
        drivers = open_drivers(patch, devices)
    return _render(patch, seconds, probes=probes, engine=engine, progress=progress, drivers=drivers,
                   safety=safety, chunk=chunk, runaway=runaway)


__all__ = ["Block", "Buffer", "In", "Out", "Param", "State", "helper", "Patch", "PatchError", "Problem",
           "Registry", "Render", "load", "render", "__version__"]
