"""What a block reads: a small typed IR with one meaning for both engines.

Every argument of every block function, every recorded value and every argument of a fused
network's step is one of these nodes. Each node says, side by side,
  emit()        its expression in the generated kernel (Python that numba compiles), and
  value(frame)  its value in the reference interpreter at one sample,
so the compiler and the interpreter cannot give one binding two meanings.

Names in emitted code come only from here and from the compiler: slots and indices are integers,
attributes and coefficient names are checked to be plain identifiers (they come from a block's
Python declarations, never from a patch's text). The kernel's locals are named after the patch
(`local`, given by Names): BLOCK_attr for a state, live parameter, coefficient, buffer or output
of block BLOCK (`loop_buf`, `damp_y1`, `damp_gain`, `loop_out`), LATTICE_x / LATTICE_v for a fused
network's positions and velocities; BLOCK is the block's name reduced to [A-Za-z0-9_] and made
unique. A node built without a name falls back to its slot: sK lK cK bK aK, oK_attr, dK.
  t        the shared sample counter (i: the sample inside the call)
  ext      the per-sample device/input columns (ext[i, col])
"""
import builtins
import keyword
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


# names the kernel module defines or reads besides the patch's locals
KERNEL_NAMES = frozenset({"math", "np", "numba", "kernel", "t", "t0", "i", "n", "state", "live", "coef",
                          "rec", "ext", "jit", "collections", "kernel_guard"})


def sanitize(text, limit=40):
    """An identifier made of `text`: every character outside [A-Za-z0-9_] becomes `_`; prefixed
    with `b_` if it is empty, starts with a digit, or is a keyword, a builtin or a kernel name."""
    name = "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in str(text)[:limit])
    if not name or name[0].isdigit() or keyword.iskeyword(name) or keyword.issoftkeyword(name) \
            or hasattr(builtins, name) or name in KERNEL_NAMES:
        name = "b_" + name
    return ident(name, "sanitized name")


class Names:
    """The kernel's names: a prefix per block (sanitized, unique among blocks) and locals built
    from it, each unique in the kernel (suffix _2, _3, ... on a clash) and never a reserved name."""

    def __init__(self, reserved=()):
        self.taken = set(KERNEL_NAMES) | set(reserved)
        self.prefixes = set()
        self.known = {}

    @staticmethod
    def _unique(base, taken):
        name, k = base, 2
        while name in taken or keyword.iskeyword(name) or hasattr(builtins, name):
            name, k = f"{base}_{k}", k + 1
        taken.add(name)
        return name

    def prefix(self, key, text):
        """The identifier block `key` (named `text` in the patch) prefixes its locals with."""
        if ("prefix", key) not in self.known:
            self.known[("prefix", key)] = self._unique(sanitize(text), self.prefixes)
        return self.known[("prefix", key)]

    def local(self, key, prefix, attr):
        """The local `prefix_attr` (attr comes from Python declarations), the same for one key."""
        if key not in self.known:
            base = f"{ident(prefix, 'name prefix')}_{ident(attr, 'attribute')}"
            self.known[key] = self._unique(base, self.taken)
        return self.known[key]


def _named(node, fallback):
    return ident(node.local, "kernel local") if node.local else fallback


def _local():
    return field(default=None, compare=False, repr=False)


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
    rec_row: Any = None
    outs: dict = field(default_factory=dict)       # (block index, attr) -> value
    derived: dict = field(default_factory=dict)    # block index -> {coefficient: value}
    bad: bool = False                              # the guard saw a bad record this call


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
    local: str = _local()

    def emit(self):
        return _named(self, f"l{int(self.slot)}")

    def load(self):
        return f"live[{int(self.slot)}]"

    def value(self, frame):
        return float(frame.live[self.slot])


# an "index" (a ring mask, a cell's place) is known to LLVM to be ≥ 0 through the mask, so that
# indexing with it needs no wraparound test for negative indices
INDEX_BITS = (1 << 48) - 1
_CASTS = {"float": "coef[{}]", "int": "int(coef[{}])", "bool": "coef[{}] != 0.0",
          "index": "(int(coef[{}]) & " + str(INDEX_BITS) + ")"}


@dataclass(frozen=True)
class Coef(Node):
    """A number the kernel reads as data: a coefficient re-derived at control rate or a static
    number of the patch, kept as a float in coef[slot] and read as its kind ('float', 'int',
    'bool', or 'index': a non-negative integer below 2**48)."""
    slot: int
    kind: str = "float"
    local: str = _local()

    def emit(self):
        return _named(self, f"c{int(self.slot)}")

    def load(self):
        return _CASTS[self.kind].format(int(self.slot))

    def value(self, frame):
        v = float(frame.coef[self.slot])
        if self.kind == "index":
            return int(v) & INDEX_BITS
        return int(v) if self.kind == "int" else (v != 0.0 if self.kind == "bool" else v)

    @staticmethod
    def kind_of(v):
        return "bool" if isinstance(v, bool) else ("int" if isinstance(v, int) else "float")


@dataclass(frozen=True)
class DerivedCoef(Node):
    """A coefficient block `block` derives every sample (a connection drives a live input)."""
    block: int
    name: str
    local: str = _local()       # the dict of the coefficients

    def emit(self):
        return f"{_named(self, f'd{int(self.block)}')}['{ident(self.name, 'coefficient name')}']"

    def value(self, frame):
        return frame.derived[self.block][self.name]


@dataclass(frozen=True)
class StateSlot(Node):
    """A block's scalar state: state[slot], held in a local inside the kernel."""
    slot: int
    local: str = _local()

    def emit(self):
        return _named(self, f"s{int(self.slot)}")

    def load(self):
        return f"state[{int(self.slot)}]"

    def value(self, frame):
        return float(frame.state[self.slot])


@dataclass(frozen=True)
class BufferRef(Node):
    """A block's ring buffer (a kernel argument, written in place)."""
    index: int
    local: str = _local()

    def emit(self):
        return _named(self, f"b{int(self.index)}")

    def value(self, frame):
        return frame.buffers[self.index]


@dataclass(frozen=True)
class ArrayRef(Node):
    """A whole array argument: a long static table, or a fused network's array."""
    index: int
    local: str = _local()

    def emit(self):
        return _named(self, f"a{int(self.index)}")

    def value(self, frame):
        return frame.arrays[self.index]


@dataclass(frozen=True)
class ArrayItem(Node):
    """One element of an array argument (a cell's position or velocity); its index is a node
    (a number the kernel reads as data, so a lattice's size never reaches the source)."""
    array: int
    index: Node
    local: str = _local()       # the array's name

    def emit(self):
        return f"{_named(self, f'a{int(self.array)}')}[{self.index.emit()}]"

    def value(self, frame):
        return float(frame.arrays[self.array][self.index.value(frame)])


@dataclass(frozen=True)
class BufferItem(Node):
    """Element `index` of a block's buffer: an output the block's `output` writes there this sample."""
    buffer: int
    index: int
    local: str = _local()       # the buffer's name

    def emit(self):
        return f"{_named(self, f'b{int(self.buffer)}')}[{int(self.index)}]"

    def value(self, frame):
        return float(frame.buffers[self.buffer][self.index])


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
    local: str = _local()

    def emit(self):
        return _named(self, f"o{int(self.block)}_{ident(self.attr, 'output attribute')}")

    def value(self, frame):
        return frame.outs[(self.block, self.attr)]
