"""Fused families: block types whose instances the compiler fuses, group by group, into ONE step.

A block type joins a family by naming it (`family = MassSpring`). Every group of the family's
blocks that touch one another (`joins`) is built into a `Group`: a few arrays (structure of
arrays, updated in place), the points a patch can address as `NAME[i, ...].PORT`, and one step
per sample. The compiler and the reference interpreter know families only through this
protocol, so a plugin adds a family (or a new link law inside one) without touching graph/.

The step's arguments are spelled with the four small values below, which the compiler turns into
kernel arguments and the interpreter into Python values, one meaning for both:
  Array(key)                  one of the group's arrays
  Number(value, kind, name, of_rate)  data: a size, a time step (loaded from an array: editing it
                              re-uses the kernel); `of_rate`: the function of the rate it is, if it is one
  Flag(value)                 structure: a literal in the kernel (a boundary kind, a branch)
  Control(block, param, inverse)  the live value of a member's parameter, or the sum of the
                              connections driving it; 1/value when `inverse`
A family's `check` reports with `problems.add(line, message)`.

A group is built once per load: each loaded instance carries `built`, a dict in which a family
may keep what it built for the group the instance leads (the mass-spring family keeps its Network
there, so its stability check, the Program and `hapticgraph modes` share one). A group that
offers a linear model subclasses LinearGroup.
"""
from dataclasses import dataclass


@dataclass(frozen=True)
class Array:
    key: str


@dataclass(frozen=True)
class Number:
    value: float
    kind: str = "float"       # "float", "int" or "index" (an integer ≥ 0)
    name: str = "n"
    of_rate: object = None    # value = of_rate(rate), a plain function a host's rate is given to (the C export)


@dataclass(frozen=True)
class Flag:
    value: bool


@dataclass(frozen=True)
class Control:
    block: str
    param: str
    inverse: bool = False


@dataclass(frozen=True)
class Change:
    """What a point's output reads when the group does not store it: the change of one array
    against another, (array[key][i] − array[before][i]) · per (a lattice stepped in one pass
    gives a cell's velocity as (x[n] − x[n−1]) · fs); `of_rate`, as Number's."""
    key: str
    before: str
    per: float
    of_rate: object = None


@dataclass(frozen=True)
class Points:
    """The points (cells) of one member of a group, as numpy views of the group's arrays: writing
    into one changes what the next step reads. `positions`, `velocities` and `forces` (the force
    each point receives in the next sample, cleared by every step) are shaped like the member
    (`shape`; () for a single cell) when it has all its cells, else one entry per cell it has
    (`cells` lists their indices, one row each). `status()` -> (locked, cut), bool arrays like
    `positions`, as they are now. A group that does not store velocities (a lattice stepped in
    one pass) gives them computed, a copy: writing into it changes nothing; it gives instead
    `previous`, the positions one sample before (views: what the next step reads), else None.
    The views need not be contiguous (a lattice's cells inside a ghost border)."""
    positions: object
    velocities: object
    forces: object
    shape: tuple
    cells: object
    status: object
    previous: object = None

    @property
    def locked(self):
        return self.status()[0]

    @property
    def cut(self):
        return self.status()[1]


class Family:
    """The protocol of a fused family (class methods; subclass it)."""

    point_ports = {}          # port of an addressed point -> "input" or "output"

    @classmethod
    def joins(cls, inst):
        """Names of the blocks a member joins (a spring: the blocks of its two cells)."""
        return ()

    @classmethod
    def link_ends(cls, inst):
        """[(block name, point as written)] of the two points a link member joins; [] otherwise."""
        return []

    @classmethod
    def check(cls, blocks, problems, declared, rate):
        """Family-wide checks (references, sizes, stability) of the family's members among
        `blocks` (every block of the patch without a problem of its own, name -> instance, so a
        reference to a block of another kind can be named). `declared`: every block name of the
        patch (also those with problems)."""

    @classmethod
    def point_problem(cls, inst, index, port, role):
        """What is wrong with `NAME[index].port` used as an `role` ('input', 'output', or
        'probe': only read), or None. By default: the port, then `index_problem`."""
        ports = cls.point_ports
        if port not in ports:
            return f"a point has no port {port!r}; its ports: {', '.join(f'{p} ({r})' for p, r in ports.items())}"
        if role != "probe" and ports[port] != role:
            return f"{port!r} is an {ports[port]}, it cannot be the {'source' if role == 'output' else 'destination'}"
        return cls.index_problem(inst, index)

    @classmethod
    def index_problem(cls, inst, index):
        """What is wrong with point `index` of member `inst`, or None."""
        return f"block {inst.name!r} ({inst.cls.type_name}) has no points to index"

    @classmethod
    def cost(cls, members):
        """How many blocks a group counts for against the one-kernel limit."""
        return 1

    @classmethod
    def build(cls, members, rate, editable=False):
        """The Group of touching members (in patch order)."""
        raise NotImplementedError


class Group:
    """One fused group: what the compiler and the interpreter read (attributes and methods)."""

    names = ()                # member block names
    arrays = {}               # key -> numpy array, each a kernel argument

    def point(self, block, index):
        """The index of point `block[index]` (index None for a one-point block) in the group's
        arrays, or None if it has no such point."""
        raise NotImplementedError

    def point_array(self, port):
        """The key of the array an output port reads, or an input port adds into."""
        raise NotImplementedError

    def reading(self, port):
        """What an output port of a point reads: an array key (its element), or a Change."""
        return self.point_array(port)

    def rotations(self):
        """[(key, key)]: pairs of arrays the kernel swaps after each step (a step that writes its
        new values over the older of two buffers); after a call both hold what they name."""
        return []

    def controls(self):
        """[(array key, (row, col), Control)]: set every sample before the step."""
        return []

    def rate_rows(self):
        """[(array key, row, function, arguments)]: rows of the group's arrays (their first values)
        computed from the rate as `function(*arguments, rate)`, a plain function (the C export
        translates it, to compute them again at a host's rate)."""
        return []

    def wired(self, points):
        """{array key: point indices} the patch adds forces into, told before `step` and before
        `arrays` is read again (a group may then replace an array, e.g. a list of driven points)."""

    def step(self):
        """(function, [Array | Number | Flag | Control]): the per-sample update, a @helper."""
        raise NotImplementedError

    def views(self, block):
        """Writable views of what `block` remembers between samples (a reload carries them), in
        the order `remembers` names them."""
        return ()

    def remembers(self, block):
        """What each of `views(block)` holds, by name (a reload carries views only between
        groups that remember the same things)."""
        return ()

    def points(self, block):
        """The Points of member `block`; ValueError if it has none to show."""
        raise ValueError(f"{block!r}: its group has no points to read")

    def edit(self, block, index, action, apply=True):
        """Change a point between kernel calls (e.g. lock, unlock, cut); ValueError if refused;
        `apply=False`: only the check."""
        raise ValueError(f"{block}: this group cannot be edited while playing")


class LinearGroup(Group):
    """A Group whose first `n` points move by a linear model, M·x″ = −K·x (damping and live
    inputs aside): what `hapticgraph modes` and `plot --mode` read. A family's group offers it by
    subclassing this (the mass-spring Network does)."""

    n = 0                     # the number of points the model covers: the group's first n

    def bodies(self):
        """Names of the members whose points the model covers, in patch order."""
        raise NotImplementedError

    def links(self):
        """Names of the members that join them."""
        return []

    def masses(self):
        """Per point: its mass [kg]; inf for a point that never moves (locked)."""
        raise NotImplementedError

    def stiffness_matrix(self):
        """K (n × n, scipy sparse) at the members' patch values."""
        raise NotImplementedError

    def notes(self, connections):
        """What the lossless linear model leaves out here, given the patch's connections."""
        return []

    def shape_of(self, block, x):
        """A vector `x` over the n points seen on `block`'s points: an array of its shape (NaN
        where it has no point)."""
        raise NotImplementedError


def touching(members, joins):
    """Members (instances with .name and .index) grouped by touch, each group in patch order,
    groups in the order of their first member: union-find over `joins(inst)` (names; names
    outside `members` are ignored)."""
    parent = {b.name: b.name for b in members}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x
    for b in members:
        for other in joins(b):
            if other in parent:
                parent[find(other)] = find(b.name)
    groups = {}
    for b in sorted(members, key=lambda b: b.index):
        groups.setdefault(find(b.name), []).append(b)
    return list(groups.values())
