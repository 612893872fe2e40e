"""The C backend: a patch's program lowered to plain C99 (libm only) beside the numba one.

`export_c(patch, name)` gives the header and the source of `name.h` / `name.c` (docs/export.md),
with the tables of its ports and parameters.
Nothing here is a second description of a block: the kernel is the source graph/codegen.py
generates, read back and translated (kernel.py), with every block function and helper it calls
translated from their own Python (expr.py, stmt.py, library.py: the numba subset blocks are
written in, anything else refused at its FILE:LINE); each block's derive, check, first states
and ring sizes are translated for the host's rate (setup.py); runtime.py is the C spelling of the
few operations C writes otherwise than Python; api.py and instance.py the API around it.
"""
from .export import export_c

__all__ = ["export_c"]
