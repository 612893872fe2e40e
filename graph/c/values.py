"""The values the C translator computes with: a C expression of a known C type, or a value known
while translating (a number, a flag, a parameter's list), which folds as Python folds it.

Types: "f" a double, "i" a 64-bit integer (Python's int as numba types it), "b" a flag (an int
0/1 in C); "arr" a float64 array (`hg_arr`: pointer and length), "arr2" a float64 matrix, "iarr",
"i32arr", "u32arr" integer arrays (NUMBER_ARRAYS); "rec" the kernel's records (`hg_rec`: the output columns) and "ext" its inputs
(`hg_ext`); "fn" a Python function or a math function, "mod" a module, "shape" an array's shape,
"known" any other value known while translating (a list, a text), never spelled in C; "tuple"
a tuple of values, "multi" a call that returns several, "none" a call that returns nothing,
"shape_K" the shape of an array of kind K, "params" a block's parameters (graph/c/setup.py).
"""
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

SCALARS = ("b", "i", "f")
# arrays of numbers: kind -> (C struct, C element type, numpy dtype); "arr2" a C-ordered matrix
NUMBER_ARRAYS = {"arr": ("hg_arr", "double", "float64"), "arr2": ("hg_arr2", "double", "float64"),
                 "iarr": ("hg_iarr", "long long", "int64"), "i32arr": ("hg_i32arr", "int32_t", "int32"),
                 "u32arr": ("hg_u32arr", "uint32_t", "uint32")}
ARRAYS = {**{k: v[0] for k, v in NUMBER_ARRAYS.items()}, "rec": "hg_rec", "ext": "hg_ext"}
# "fp": the floating-point environment saved around the sample loop (graph/fpenv.py's flush_enter)
C_TYPES = {"f": "double", "i": "long long", "b": "int", "fp": "hg_fpenv", **ARRAYS}
NOTHING = object()


class Refused(Exception):
    """Something the translator does not lower to C, at a file and line of Python source."""

    def __init__(self, file, line, message):
        super().__init__(f"{file}:{line}: {message}")
        self.file, self.line, self.message = file, line, message
        self.via = ()       # the functions it was found in, innermost first (graph/c/library.py)


@dataclass
class Val:
    """A value: `kind` (see the module's doc), its C text `c` (None when known), `known` (the
    Python value when it is known while translating), `nonneg` (an integer known ≥ 0, so an
    index needs no wraparound test)."""
    kind: str
    c: str = None
    known: Any = NOTHING
    nonneg: bool = False
    items: tuple = ()        # a tuple's values; a call's (arguments' text, kinds it returns)

    @property
    def is_known(self):
        return self.known is not NOTHING

    @property
    def scalar(self):
        return self.kind in SCALARS


def array_kind(array):
    """The kind of a numpy array the kernel takes; ValueError for one C is not given."""
    for kind, (_, _, dtype) in NUMBER_ARRAYS.items():
        if array.dtype == np.dtype(dtype) and array.ndim == (2 if kind == "arr2" else 1):
            if array.ndim == 2 and not array.flags.c_contiguous:
                break
            return kind
    raise ValueError(f"an array of {array.dtype} in {array.ndim} dimension(s)")


def kind_of(value):
    """The type of a value known while translating."""
    if isinstance(value, bool):
        return "b"
    if isinstance(value, int):
        return "i"
    if isinstance(value, float):
        return "f"
    return "known"


def known(value):
    """A known value (numpy scalars as Python's)."""
    if isinstance(value, np.generic):
        value = value.item()
    return Val(kind_of(value), known=value, nonneg=kind_of(value) in ("i", "b") and value >= 0)


def join(a, b):
    """The type a variable assigned both takes (numba's unification: a flag and an integer give an
    integer, either and a double a double); None if they do not join."""
    if a is None or a == b:
        return b
    if a in SCALARS and b in SCALARS:
        return SCALARS[max(SCALARS.index(a), SCALARS.index(b))]
    return None


def literal(value):
    """C text of a number known while translating: exact (a double's shortest repr reads back to
    the same bits), None for anything that is not a number."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        if -(1 << 31) < value < (1 << 31):
            return str(value) if value >= 0 else f"({value})"
        return f"{value}LL" if value >= 0 else f"({value}LL)"
    if isinstance(value, float):
        if math.isnan(value):
            return "NAN"
        if math.isinf(value):
            return "INFINITY" if value > 0 else "(-INFINITY)"
        spelled = repr(value)
        return f"({spelled})" if spelled.startswith("-") else spelled
    return None


def text(v):
    """The C text of a scalar value (a known one spelled as a literal); None if it has none."""
    if v.is_known:
        return literal(v.known)
    return v.c


def as_double(v):
    """C text of v converted to double (an integer or flag cast; a known integer as a double literal)."""
    if v.is_known and isinstance(v.known, (bool, int)):
        return literal(float(v.known))
    return text(v) if v.kind == "f" else f"(double)({text(v)})"


__all__ = ["ARRAYS", "NUMBER_ARRAYS", "array_kind", "C_TYPES", "NOTHING", "SCALARS", "Refused", "Val", "as_double", "join", "kind_of", "known",
           "literal", "text"]
