"""Fused families in the compiler: grouping, checks, and each group as one schedule item.

A block type names its family (`family = ...`, a `hapticgraph.blocks.family.Family`); this
module knows families only through that protocol. `groups` groups a patch's family members by
touch, `check_families` runs each family's checks, and a `GroupStep` plans one built group: its
arrays become kernel arguments named after the group's first member (`str_x`, `str_v`), the
points the patch wires become numbers (data), the forces wired into points are summed into the
group's input array, its controls and step arguments become IR nodes (graph/ir.py) — one
meaning, emitted for the kernel and evaluated by the interpreter.
"""
from ..blocks.family import Array, Change, Control, Flag, Number, touching
from ..blocks.vocabulary import arguments, helper
from .codegen import emit_call
from .identifiers import note
from .ir import ArrayItem, Difference, Inverse, Literal, Total


def family_of(inst):
    return getattr(inst.cls, "family", None)


def members(blocks, family):
    return {name: b for name, b in blocks.items() if family_of(b) is family}


def families(blocks):
    """The families of a patch's blocks, in order of first appearance."""
    return list(dict.fromkeys(f for f in map(family_of, sorted(blocks.values(), key=lambda b: b.index)) if f))


def groups(blocks):
    """[(family, members)]: every group of touching members of each family, in patch order."""
    out = []
    for family in families(blocks):
        out += [(family, g) for g in touching(list(members(blocks, family).values()), family.joins)]
    return out


def check_families(blocks, problems, declared, rate):
    for family in families(blocks):
        family.check(blocks, problems, declared, rate)


def kernel_cost(blocks):
    """What one kernel compiles, in blocks: every block outside a family, and each group's cost."""
    return sum(1 for b in blocks.values() if family_of(b) is None) + sum(
        family.cost(g) for family, g in groups(blocks))


@helper
def exchange(a, b):
    """Swap the contents of two arrays of one length (a rotation's end, after an odd number of
    samples: each array then holds what it is named for again)."""
    for i in range(a.shape[0]):
        t = a[i]
        a[i] = b[i]
        b[i] = t


class GroupStep:
    """One fused group's plan and its schedule item: the wired forces added into its points, its
    controls set, then its step — after every block's update, each sample."""

    def __init__(self, prog, family, group):
        self.prog, self.family, self.group = prog, family, group
        self.prefix = prog.by_name[group.names[0]].ident
        self.arrays = {}                 # key -> ArrayRef
        for key, value in group.arrays.items():
            self.arrays[key] = prog.array(value, self.prefix, key)
        self.points = {}                 # point index (or a Change's scale) -> its number node
        self.forces = {}                 # (array key, point index) -> [sources]
        self.sets, self.call = [], None
        self.rated = []                  # (number node, function of the rate it is): Number.of_rate, Change.of_rate
        self.rate_rows = []              # (ArrayRef, row, function, arguments): Group.rate_rows

    def point(self, end):
        """The point index of an endpoint, or None."""
        return self.group.point(end.block, end.index)

    def _index(self, flat):
        if flat not in self.points:
            self.points[flat] = self.prog.number(flat, "index", self.prefix, f"p{len(self.points)}")
        return self.points[flat]

    def element(self, end):
        """What a connection from a point's output port reads: one element of a group array, or
        the change of one against another (a Change: a velocity not stored)."""
        read = self.group.reading(end.port)
        if isinstance(read, Change):
            key = ("per", read.key, read.before, read.per)
            if key not in self.points:
                self.points[key] = self._number(read.per, "float", f"per_{read.key}_{read.before}", read.of_rate)
            return Difference(self._item(read.key, end), self._item(read.before, end), self.points[key])
        return self._item(read, end)

    def _number(self, value, kind, name, of_rate):
        node = self.prog.number(value, kind, self.prefix, name)
        if of_rate is not None:
            self.rated.append((node, of_rate))
        return node

    def _item(self, key, end):
        ref = self.arrays[key]
        return ArrayItem(ref.index, self._index(self.point(end)), ref.local)

    def add_force(self, end, source):
        key = (self.group.point_array(end.port), self.point(end))
        self._index(key[1])
        self.forces.setdefault(key, []).append(source)

    def driven(self, end):
        """The sum of what is wired into a point's input port."""
        return Total(tuple(self.forces.get((self.group.point_array(end.port), self.point(end)), ())))

    def _node(self, arg, name):
        prog = self.prog
        if isinstance(arg, Array):
            return self.arrays[arg.key]
        if isinstance(arg, Number):
            return self._number(arg.value, arg.kind, arg.name, arg.of_rate)
        if isinstance(arg, Flag):
            return Literal(bool(arg.value), f"{self.prefix}: {name}")
        if isinstance(arg, Control):
            node = prog.param_binding(prog.by_name[arg.block], arg.param)
            return Inverse(node) if arg.inverse else node
        raise TypeError(f"a family step argument must be Array, Number, Flag or Control, not {arg!r}")

    def bind(self):
        """Controls and step arguments as IR nodes (once live slots exist)."""
        wired = {}
        for key, flat in self.forces:
            wired.setdefault(key, []).append(flat)
        self.group.wired(wired)
        for key, value in self.group.arrays.items():     # the group may have replaced one
            self.prog.arrays[self.arrays[key].index] = value
        self.sets = [(self.arrays[key], tuple(int(i) for i in at), self._node(c, key))
                     for key, at, c in self.group.controls()]
        fn, args = self.group.step()
        names = arguments(fn) + ("",) * len(args)       # a literal is named after its argument
        self.call = (fn, [self._node(a, names[k]) for k, a in enumerate(args)])
        self.rotations = [(self.arrays[a], self.arrays[b]) for a, b in self.group.rotations()]
        self.rate_rows = [(self.arrays[key], row, fn, args) for key, row, fn, args in self.group.rate_rows()]

    # -- the schedule-item protocol ------------------------------------------------------------
    def functions(self):
        return [self.call[0]]

    def ends(self):
        return [exchange] if self.rotations else []

    def emit(self, e):
        e(f"# {note(', '.join(self.group.names))} ({note(self.family.__name__)} group)")
        for (key, flat), sources in self.forces.items():
            e(f"{self.arrays[key].emit()}[{self.points[flat].emit()}] += {Total(tuple(sources)).emit()}")
        for ref, at, node in self.sets:
            e(f"{ref.emit()}[{', '.join(map(str, at))}] = {node.emit()}")
        fn, args = self.call
        emit_call(e, "", fn.__name__, args)
        for a, b in self.rotations:
            e(f"{a.emit()}, {b.emit()} = {b.emit()}, {a.emit()}")

    def emit_end(self, e):
        """After the sample loop: an odd number of rotations leaves each buffer holding what the
        other is named for; swapping their contents puts them back."""
        for a, b in self.rotations:
            e("if n % 2 == 1:")
            e(f"    exchange({a.emit()}, {b.emit()})")

    def end(self, frame, n):
        """The interpreter's emit_end: the arrays put back in their slots, contents swapped."""
        for a, b in self.rotations:
            if n % 2 == 1:
                arrays = frame.arrays
                arrays[a.index], arrays[b.index] = arrays[b.index], arrays[a.index]
                exchange(arrays[a.index], arrays[b.index])

    def run(self, frame):
        for (key, flat), sources in self.forces.items():
            frame.arrays[self.arrays[key].index][self.points[flat].value(frame)] += Total(tuple(sources)).value(frame)
        for ref, at, node in self.sets:
            frame.arrays[ref.index][at] = node.value(frame)
        fn, args = self.call
        fn(*[a.value(frame) for a in args])
        for a, b in self.rotations:
            arrays = frame.arrays
            arrays[a.index], arrays[b.index] = arrays[b.index], arrays[a.index]
