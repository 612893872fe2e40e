"""A patch that leaves Python (docs/export.md): its program lowered to C99 by the C backend
(hapticgraph.graph.c), written as `NAME.h` / `NAME.c` (`to="c"`), or built with the system's C
compiler into an LV2 bundle `NAME.lv2/` (`to="lv2"`).

    from hapticgraph.export import export
    written = export("patches/karplus_strong.yaml", "c", "build/ks")

A block that cannot be lowered is a PatchError (`FILE:LINE: message` per problem, exit status 2
on the command line); a build that fails is an ExportError.
"""
from .bundle import export, export_name
from .compiler import ExportError

__all__ = ["ExportError", "export", "export_name"]
