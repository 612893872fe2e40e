"""The patch data model: endpoints, connections, block instances, a patch and its subsets.

Frozen dataclasses: the loader (graph/patch.py) fills them once, checked, and nothing rebuilds
them by hand; a part of a patch is made with `Patch.subset` (the compiler's check of one plugin
block, graph/isolate.py, compiles such a part).
"""
import re
from dataclasses import dataclass, field, replace
from typing import Any

from ..blocks.numbers import whole_number
from .patterns import INDEX

_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
_ENDPOINT = re.compile(rf"\s*({_NAME})(?:\[([^\]]*)\])?\.({_NAME})\s*")
_INDEX = re.compile(INDEX)     # the schema's: `[i, j]` of whole numbers


@dataclass(frozen=True)
class Endpoint:
    """`block.port` or `block[i, j].port` in a connection (index: a tuple of ints, or None)."""
    block: str
    index: Any
    port: str

    def __str__(self):
        idx = "" if self.index is None else "[" + ", ".join(map(str, self.index)) + "]"
        return f"{self.block}{idx}.{self.port}"

    @classmethod
    def parse(cls, text):
        """An Endpoint, or None if `text` cannot be read (`problem` says why)."""
        m = _ENDPOINT.fullmatch(text)
        if not m or (m.group(2) is not None and not _INDEX.fullmatch(f"[{m.group(2)}]")):
            return None
        index = None if m.group(2) is None else tuple(whole_number(v) for v in m.group(2).split(","))
        return cls(m.group(1), index, m.group(3))

    @staticmethod
    def problem(text):
        """Why `text` is not an endpoint: a sentence, or None if it is one."""
        m = _ENDPOINT.fullmatch(text)
        if m is None:
            return "write block.port, or name[i, j].port for a cell"
        if m.group(2) is not None and not _INDEX.fullmatch(f"[{m.group(2)}]"):
            return (f"the cell index [{m.group(2)}] must be whole numbers separated by commas, "
                    f"e.g. {m.group(1)}[1, 2].{m.group(3)}")
        return None


def connection_problem(text):
    """Why the text of a connection cannot be read, as the loader reports it."""
    left, arrow, right = text.partition("->")
    if arrow:
        for side in (left, right):
            reason = Endpoint.problem(side)
            if reason and "cell index" in reason:
                return f"cannot read {text.strip()!r}: {reason}"
    return f"cannot read {text!r}: write \"block.port -> block.port\""


@dataclass(frozen=True)
class Connection:
    """`src -> dst`, at `line` of the patch."""
    src: Endpoint
    dst: Endpoint
    line: int

    def __str__(self):
        return f"{self.src} -> {self.dst}"


@dataclass(frozen=True, eq=False)
class Instance:
    """One block of a patch: its type, parameter values (defaults filled in), where it is written
    (`line`, and `lines` of its keys), its place in the patch (`index`) and its ports."""
    name: str
    cls: Any
    values: dict
    line: int
    lines: dict
    index: int
    inputs: tuple = field(init=False, compare=False)
    outputs: tuple = field(init=False, compare=False)
    # what its family built at load for the group it leads (blocks/family.py): one network per load
    built: dict = field(init=False, compare=False, repr=False, default_factory=dict)

    def __post_init__(self):
        inputs, outputs = self.cls.ports(self.values)
        object.__setattr__(self, "inputs", tuple(inputs))
        object.__setattr__(self, "outputs", tuple(outputs))

    @property
    def params(self):
        return self.cls.param_tuple()(**self.values)

    def input(self, name):
        """The In port (or live parameter name) called `name`, or None."""
        for port in self.inputs:
            if port.name == name:
                return port
        param = self.cls.params.get(name)
        return param if param is not None and param.live else None

    def output(self, name):
        for port in self.outputs:
            if port.name == name:
                return port
        return None

    def line_of(self, key):
        return self.lines.get(key, self.line)


@dataclass(frozen=True, eq=False)
class Patch:
    """A checked patch: blocks (name -> Instance), connections, devices (its `devices:` section)
    and the schedule (`order`: block names), the document it was read from and the registry of
    its block types and drivers."""
    file: str
    doc: Any
    name: str
    rate: float
    blocks: dict
    connections: list
    devices: Any
    order: list
    registry: Any

    def __repr__(self):
        return f"<Patch {self.name!r} from {self.file}: {len(self.blocks)} blocks at {self.rate:g} Hz>"

    def subset(self, blocks, connections=(), devices=None, name=None):
        """A part of this patch (or blocks added to it): `blocks` (Instances, in schedule order),
        the `connections` between them, `devices` (a mapping; default: all of this patch's) and
        `name` (default: this patch's); its file, document, rate and registry are this patch's."""
        blocks = list(blocks)
        return replace(self, name=self.name if name is None else name, blocks={b.name: b for b in blocks},
                       connections=list(connections), order=[b.name for b in blocks],
                       devices=self.devices if devices is None else devices)
