"""What `hapticgraph export` writes: the C files, or an LV2 bundle built from them."""
import os
import re

from ..devices.midi_c import midi_hosted
from ..graph.c import export_c
from ..graph.patch import load
from .compiler import ExportError, write_sources
from .lv2 import write_bundle
from .wasm import write_wasm

TARGETS = ("c", "lv2", "wasm")


def export_name(path):
    """The default C prefix of a patch file: its name, reduced to an identifier."""
    stem = os.path.splitext(os.path.basename(os.fspath(path)))[0]
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem) or "patch"
    return name if not name[0].isdigit() else f"p_{name}"


def lower(patch, name):
    """`patch` lowered to C under the prefix `name` (graph/c/export.CPlan), its MIDI blocks played
    from the events NAME_midi gives (hapticgraph.devices.midi_c)."""
    return export_c(patch, name, hosted=midi_hosted)


def write_c(lowered, out):
    """NAME.h and NAME.c in the folder `out` (made if needed); their paths."""
    return write_sources(out, {f"{lowered.name}.h": lowered.header, f"{lowered.name}.c": lowered.source})


def export(patch, to, out, name=None, overrides=(), install=False):
    """Export `patch` (a Patch, or a path loaded with `overrides`) `to` "c", "lv2" or "wasm" into the
    folder `out`; the paths written. PatchError for a patch that cannot be lowered, ExportError
    for a build that fails, ValueError for a target not offered."""
    if to not in TARGETS:
        raise ValueError(f"unknown target {to!r}; one of {', '.join(TARGETS)}")
    if isinstance(patch, (str, os.PathLike)):
        patch = load(patch, overrides=overrides)
    lowered = lower(patch, name or export_name(patch.file))
    if to == "c":
        return write_c(lowered, out)
    if to == "wasm":
        return write_wasm(lowered, out)
    return write_bundle(lowered, out, install=install)


__all__ = ["TARGETS", "export", "export_name", "lower", "write_c", "ExportError"]
