"""What a block reads: a small typed IR with one meaning for both engines.

Every argument of every block function, every recorded value and every argument of a fused
network's step is one of these nodes. Each node says, side by side,
  emit()        its expression in the generated kernel (Python that numba compiles), and
  value(frame)  its value in the reference interpreter at one sample,
so the compiler and the interpreter cannot give one binding two meanings.

Names in emitted code come only from here and from the compiler: slots and indices are integers,
attributes and coefficient names are checked to be plain identifiers (they come from a block's
Python declarations, never from a patch's text). The kernel's locals follow one convention:
  t        the shared sample counter (i: the sample inside the call)
  sK lK cK state slot K, live slot K, coefficient slot K (loaded before the sample loop)
  bK aK    buffer K, array K (kernel arguments)
  ext      the per-sample device/input columns (ext[i, col])
  oK_attr  output `attr` of block K of the schedule; dK the coefficients block K derives per sample
"""
import math
import re
from dataclasses import dataclass, field
from typing import Any

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class KernelSourceError(TypeError):
    """A name that would reach the generated source is not a plain identifier."""


def ident(name, what):
    """`name` if it is an ASCII identifier matched whole, else KernelSourceError."""
    if not isinstance(name, str) or not _IDENT.fullmatch(name):
        raise KernelSourceError(f"{what} {name!r} is not a plain identifier; it cannot be compiled")
    return name


def lit(v):
    """A Python literal for a static value (numba reads it as a compile-time constant)."""
    if isinstance(v, bool):
        return "True" if v else "False"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "math.nan"
        if math.isinf(v):
            return "math.inf" if v > 0 else "-math.inf"
        return repr(v)
    if isinstance(v, str):
        # spelled as code points, so no text of a patch is pasted into the source
        return '"' + "".join(f"\\U{ord(c):08x}" for c in v) + '"'
    if isinstance(v, tuple):
        return "(" + "".join(lit(float(x)) + ", " for x in v) + ")"
    raise TypeError(f"no literal for {v!r}")


@dataclass
class Frame:
    """What the interpreter reads at one sample: the program's arrays (shared, updated in place)
    and this sample's counter, device row, block outputs and per-sample coefficients."""
    state: Any
    live: Any
    coef: Any
    buffers: Any
    arrays: Any
    t: int = 0
    ext_row: Any = None
    outs: dict = field(default_factory=dict)       # (block index, attr) -> value
    derived: dict = field(default_factory=dict)    # block index -> {coefficient: value}


class Node:
    """A value a block reads. `atomic`: its emitted text needs no parentheses as an operand."""
    atomic = True

    def emit(self):
        raise NotImplementedError

    def value(self, frame):
        raise NotImplementedError

    def operand(self):
        """The emitted expression, parenthesised unless it is one token."""
        text = self.emit()
        return text if self.atomic else f"({text})"


@dataclass(frozen=True)
class Literal(Node):
    """A static value baked into the source: a number, a flag, a short tuple of floats."""
    constant: Any

    @property
    def atomic(self):
        return not self.emit().startswith("-")

    def emit(self):
        return lit(self.constant)

    def value(self, frame):
        return self.constant


@dataclass(frozen=True)
class Sum(Node):
    """The sum of several connections into one input, left to right; 0.0 when there is none."""
    terms: tuple

    @property
    def atomic(self):
        return len(self.terms) <= 1 and all(term.atomic for term in self.terms)

    def emit(self):
        if not self.terms:
            return "0.0"
        if len(self.terms) == 1:
            return self.terms[0].emit()
        return " + ".join(term.operand() for term in self.terms)

    def value(self, frame):
        if not self.terms:
            return 0.0
        total = self.terms[0].value(frame)
        for term in self.terms[1:]:
            total = total + term.value(frame)
        return total


@dataclass(frozen=True)
class Inverse(Node):
    """1 / of (a live mass read as an inverse mass)."""
    of: Node
    atomic = False

    def emit(self):
        return f"1.0 / {self.of.operand()}"

    def value(self, frame):
        return 1.0 / self.of.value(frame)


@dataclass(frozen=True)
class Counter(Node):
    """The kernel's shared sample counter t."""

    def emit(self):
        return "t"

    def value(self, frame):
        return frame.t


@dataclass(frozen=True)
class Live(Node):
    """An unconnected live parameter: live[slot], changed between kernel calls."""
    slot: int

    def emit(self):
        return f"l{int(self.slot)}"

    def load(self):
        return f"live[{int(self.slot)}]"

    def value(self, frame):
        return float(frame.live[self.slot])


_CASTS = {"float": "coef[{}]", "int": "int(coef[{}])", "bool": "coef[{}] != 0.0"}


@dataclass(frozen=True)
class Coef(Node):
    """A coefficient re-derived at control rate, kept as a float in coef[slot] and read as its
    kind ('float', 'int' or 'bool')."""
    slot: int
    kind: str = "float"

    def emit(self):
        return f"c{int(self.slot)}"

    def load(self):
        return _CASTS[self.kind].format(int(self.slot))

    def value(self, frame):
        v = float(frame.coef[self.slot])
        return int(v) if self.kind == "int" else (v != 0.0 if self.kind == "bool" else v)

    @staticmethod
    def kind_of(v):
        return "bool" if isinstance(v, bool) else ("int" if isinstance(v, int) else "float")


@dataclass(frozen=True)
class DerivedCoef(Node):
    """A coefficient block `block` derives every sample (a connection drives a live input)."""
    block: int
    name: str

    def emit(self):
        return f"d{int(self.block)}['{ident(self.name, 'coefficient name')}']"

    def value(self, frame):
        return frame.derived[self.block][self.name]


@dataclass(frozen=True)
class StateSlot(Node):
    """A block's scalar state: state[slot], held in a local inside the kernel."""
    slot: int

    def emit(self):
        return f"s{int(self.slot)}"

    def load(self):
        return f"state[{int(self.slot)}]"

    def value(self, frame):
        return float(frame.state[self.slot])


@dataclass(frozen=True)
class BufferRef(Node):
    """A block's ring buffer (a kernel argument, written in place)."""
    index: int

    def emit(self):
        return f"b{int(self.index)}"

    def value(self, frame):
        return frame.buffers[self.index]


@dataclass(frozen=True)
class ArrayRef(Node):
    """A whole array argument: a long static table, or a fused network's array."""
    index: int

    def emit(self):
        return f"a{int(self.index)}"

    def value(self, frame):
        return frame.arrays[self.index]


@dataclass(frozen=True)
class ArrayItem(Node):
    """One element of an array argument: a cell's position or velocity."""
    array: int
    index: int

    def emit(self):
        return f"a{int(self.array)}[{int(self.index)}]"

    def value(self, frame):
        return float(frame.arrays[self.array][self.index])


@dataclass(frozen=True)
class Column(Node):
    """This sample's value of a device or input column, which a driver supplies."""
    col: int

    def emit(self):
        return f"ext[i, {int(self.col)}]"

    def value(self, frame):
        return float(frame.ext_row[self.col])


@dataclass(frozen=True)
class Output(Node):
    """Output `attr` of the block at `block` in the schedule, computed earlier this sample."""
    block: int
    attr: str

    def emit(self):
        return f"o{int(self.block)}_{ident(self.attr, 'output attribute')}"

    def value(self, frame):
        return frame.outs[(self.block, self.attr)]


@dataclass(frozen=True)
class Mask(Node):
    """A ring buffer's size − 1, for indexing through the shared counter (a literal)."""
    mask: int

    def emit(self):
        return str(int(self.mask))

    def value(self, frame):
        return self.mask
