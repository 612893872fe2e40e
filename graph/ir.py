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
from dataclasses import dataclass, field
from typing import Any

from .identifiers import KERNEL_NAMES, KernelSourceError, Names, ident, lit, sanitize  # noqa: F401  (the IR's spelling)


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
    """A static value baked into the source: a flag, a choice, a ring's mask (structure: changing
    it compiles another kernel). `name` says what it is (`loop: line ring mask`, compiler text and
    names reduced to [A-Za-z0-9_]); the code generator writes it as a comment beside the value."""
    constant: Any
    name: str = field(default=None, compare=False)

    @property
    def atomic(self):
        return not self.emit().startswith("-")

    def emit(self):
        return lit(self.constant)

    def value(self, frame):
        return self.constant


@dataclass(frozen=True)
class Total(Node):
    """The sum of several connections into one input, left to right; 0.0 when there is none.
    (Named apart from the `sum` block type, which adds signals inside a patch.)"""
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
class Difference(Node):
    """(a − b) · per: a value a group does not store, computed where read (a cell's velocity
    from its position now and one sample before)."""
    a: Node
    b: Node
    per: Node
    atomic = False

    def emit(self):
        return f"({self.a.emit()} - {self.b.emit()}) * {self.per.emit()}"

    def value(self, frame):
        return (self.a.value(frame) - self.b.value(frame)) * self.per.value(frame)


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
