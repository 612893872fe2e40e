"""The block vocabulary: a block type declares ports, parameters, states and buffers, and three
plain functions (`derive`, `output`, `update`) that bind their arguments by name.

A block type declares and never runs; the graph layer reads these declarations to validate
patches, schedule the graph, generate the kernel and run the reference interpreter.
"""
import collections
import re

import numpy as np

from .definition import BlockDefinitionError, arguments, check_definition


class _Declaration:
    attr = None  # the attribute name on the class, set by Block.__init_subclass__

    def __set_name__(self, owner, name):
        self.attr = name


class _Port(_Declaration):
    def __init__(self, name=None, doc="", sends=False):
        self._name = name
        self.doc = doc
        self.sends = sends     # an input whose value this block's device driver receives (a force)

    @property
    def name(self):
        return self._name or self.attr


class In(_Port):
    """An input port; `name` is its public name in patches when the attribute name differs."""


class Out(_Port):
    """An output port; `name` is its public name in patches when the attribute name differs.

    `element` (buffer attribute, index): the port's value is that element of one of the block's
    buffers, which its `output` writes each sample — how a block whose outputs vary in number
    (declared by `ports(values)`) computes them.
    """

    def __init__(self, name=None, doc="", element=None):
        super().__init__(name, doc)
        self.element = element


class Param(_Declaration):
    """A parameter: default, SI unit, inclusive `minimum`/`maximum`, exclusive `above`/`below`.

    The kind follows the default: a float is a number (live unless `live=False`: it can be set
    while playing and is also an input port), an int an integer, a bool a flag, a list or tuple a
    list of numbers, a str one of `choices` (or any string when no choices are given). Only
    numbers can be live.
    """

    def __init__(self, default, unit="", minimum=None, maximum=None, above=None, below=None,
                 live=None, choices=None, doc="", min_items=None, max_items=None, refers=None,
                 internal=False, schema=None):
        self.default = default
        self.data_schema = schema  # structured data (e.g. lists of cell indices): this JSON Schema
        self.internal = internal  # set by the engine (e.g. from a device entry), never by a patch
        # "devices": the value must name an entry of the patch's devices; "file": a file beside the
        # patch; "controller": a controller device entry; "voice" / "voices": set per copy by a
        # `voices:` template (the copy's number from 1, the group's size)
        self.refers = refers
        self.unit = unit
        self.minimum, self.maximum, self.above, self.below = minimum, maximum, above, below
        self.choices = tuple(choices) if choices is not None else None
        self.doc = doc
        self.min_items, self.max_items = min_items, max_items
        self.kind = "data" if schema is not None else _kind_of(default)
        if live is None:
            live = self.kind == "number"
        self.live = bool(live)

    @property
    def name(self):
        return self.attr

    def schema(self):
        """The JSON Schema of this parameter's value in a patch."""
        bounds = {}
        for key, value in (("minimum", self.minimum), ("maximum", self.maximum),
                           ("exclusiveMinimum", self.above), ("exclusiveMaximum", self.below)):
            if value is not None:
                bounds[key] = value
        if self.kind == "number":
            s = {"type": "number", **bounds}
        elif self.kind == "integer":
            s = {"type": "integer", **bounds}
        elif self.kind == "boolean":
            s = {"type": "boolean"}
        elif self.kind == "data":
            s = dict(self.data_schema)
        elif self.kind == "list":
            s = {"type": "array", "items": {"type": "number", **bounds}}
            if self.min_items is not None:
                s["minItems"] = self.min_items
            if self.max_items is not None:
                s["maxItems"] = self.max_items
        elif self.choices:
            s = {"enum": list(self.choices)}
        else:
            s = {"type": "string"}
        desc = self.doc or ""
        if self.unit:
            desc = f"{desc} [{self.unit}]".strip()
        if self.live:
            desc = f"{desc} (live)".strip()
        if desc:
            s["description"] = desc
        s["default"] = list(self.default) if self.kind == "list" else self.default
        return s

    def value_of(self, raw):
        """The Python value of a checked patch value."""
        if self.kind == "number":
            return float(raw)
        if self.kind == "list":
            return np.asarray(list(raw), dtype=np.float64)
        if self.kind == "data":
            return _plain(raw)
        return raw


class State(_Declaration):
    """A float64 state variable: `update` returns its next value (in declaration order).

    `initial` is a number or `initial(p, fs) -> number` (e.g. a noise seed).
    """

    def __init__(self, initial=0.0, doc=""):
        self.initial = initial if callable(initial) else float(initial)
        self.doc = doc

    def value(self, p, fs):
        return float(self.initial(p, fs)) if callable(self.initial) else self.initial

    @property
    def name(self):
        return self.attr


class External(_Declaration):
    """A per-sample value supplied from outside the patch: a device's sensor or a live input.

    The engine's driver for the block's device writes it, one column per External, before each
    block of samples; functions bind it by its attribute name like an input (it never feeds a
    loop: nothing in the patch computes it).
    """

    def __init__(self, doc=""):
        self.doc = doc

    @property
    def name(self):
        return self.attr


class Buffer(_Declaration):
    """A float64 ring buffer of at least `size` samples (an int, or `size(p, fs) -> int`).

    Its length is rounded up to a power of two; functions index it with the kernel's shared
    sample counter `t` and the literal mask bound as `<name>_mask`: `buf[(t - d) & buf_mask]`.
    """

    def __init__(self, size, doc=""):
        self.size = size
        self.doc = doc

    @property
    def name(self):
        return self.attr

    def length(self, p, fs):
        n = self.size(p, fs) if callable(self.size) else self.size
        n = max(1, int(n))
        return 1 << (n - 1).bit_length()


def _kind_of(default):
    if isinstance(default, bool):
        return "boolean"
    if isinstance(default, int):
        return "integer"
    if isinstance(default, float):
        return "number"
    if isinstance(default, (list, tuple, np.ndarray)):
        return "list"
    if isinstance(default, str):
        return "string"
    raise BlockDefinitionError(f"unsupported parameter default {default!r}")


def _snake(name):
    return re.sub(r"(?<=[a-z0-9])([A-Z])", r"_\1", name).lower()


class Block:
    """Base class of every block type. Subclass it with `class Delay(Block, name="delay")`."""

    type_name = None
    inputs = ()      # In declarations, in order
    outputs = ()     # Out declarations, in order
    params = {}      # name -> Param
    states = ()      # State declarations, in order
    buffers = ()     # Buffer declarations, in order
    externals = ()   # External declarations, in order
    notes = ""       # rules the block reference prints under the equation (what a table cannot say)
    # The names of derive's values that are the kernel's structure: compiled in as literals (a
    # flag, a choice), so numba folds their branches and changing one compiles another kernel.
    # Every other value derive returns is data: a number is read from an array (editing it
    # re-uses the compiled kernel), a tuple is an array argument.
    structure = ()
    derive = None
    output = None
    update = None
    family = None    # the fused family (blocks/family.py) whose groups the block joins, or None

    def __init_subclass__(cls, name=None, abstract=False, **kwargs):
        super().__init_subclass__(**kwargs)
        if abstract:
            return
        cls.type_name = name or cls.__dict__.get("type_name") or _snake(cls.__name__)
        decls = {}
        for klass in reversed(cls.__mro__):
            for attr, value in vars(klass).items():
                if isinstance(value, _Declaration):
                    decls[attr] = value
        cls.inputs = tuple(d for d in decls.values() if isinstance(d, In))
        cls.outputs = tuple(d for d in decls.values() if isinstance(d, Out))
        cls.params = {d.attr: d for d in decls.values() if isinstance(d, Param)}
        cls.states = tuple(d for d in decls.values() if isinstance(d, State))
        cls.buffers = tuple(d for d in decls.values() if isinstance(d, Buffer))
        cls.externals = tuple(d for d in decls.values() if isinstance(d, External))
        check_definition(cls)

    # -- helpers used by the graph layer -------------------------------------------------------
    @classmethod
    def ports(cls, values):
        """(inputs, outputs) of a block with these parameter values; dynamic blocks override."""
        return cls.inputs, cls.outputs

    @classmethod
    def check(cls, p, fs):
        """Cross-parameter checks beyond the schema: yield (param name or None, message)."""
        return ()

    @classmethod
    def caption(cls, values):
        """A few words drawn under the block's name in `hapticgraph graph` (e.g. a lattice's shape)."""
        return ""

    @classmethod
    def param_tuple(cls):
        return collections.namedtuple(f"{cls.__name__}Params", list(cls.params))

    @classmethod
    def default_params(cls):
        return {n: _normalise(p.default, p.kind) for n, p in cls.params.items()}

    @classmethod
    def schema(cls):
        props = {"type": {"const": cls.type_name}}
        props.update({n: p.schema() for n, p in cls.params.items() if not p.internal})
        s = {"type": "object", "properties": props, "required": ["type"],
             "additionalProperties": False}
        doc = (cls.__doc__ or "").strip().splitlines()
        if doc:
            s["description"] = doc[0]
        return s

    @classmethod
    def feedthrough(cls):
        """Public input names that `output` (or a per-sample `derive`) reads in the same sample."""
        args = set(arguments(cls.output)) if cls.output else set()
        names = {i.name for i in cls.inputs if i.attr in args}
        names |= {n for n, p in cls.params.items() if p.live and n in args}
        return names | {n for n in cls.derive_reads if cls.params[n].live}

    @classmethod
    def coefficient_names(cls, fs=44100.0):
        if cls.derive is None:
            return ()
        p = cls.param_tuple()(**cls.default_params())
        return tuple(cls.derive(p, fs))


def _plain(value):
    """Plain lists/dicts/scalars (the patch's located containers stripped)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _normalise(value, kind=None):
    if kind == "data":
        return _plain(value)
    if isinstance(value, (list, tuple)):
        return np.asarray(value, dtype=np.float64)
    return value


_HELPERS = []   # @helper functions not yet registered with numba


def helper(fn):
    """Mark a plain function that block functions call, so the compiled kernel can call it too.

    In Python it stays the same function (the reference interpreter calls it as is). It is
    registered with numba when a kernel is first compiled (register_helpers), so that loading
    and checking a patch never imports numba.
    """
    _HELPERS.append(fn)
    return fn


def pending_helpers():
    """The @helper functions defined since the last register_helpers (a new tuple)."""
    return tuple(_HELPERS)


def register_helpers(cached=None):
    """Register every @helper defined so far with numba (register_jitable); the compiler calls this
    before it jits anything. `cached(fn)`: True to have numba cache fn's machine code (where its
    cache locators say: the compiler's graph/helper_cache.py claims those it keeps)."""
    from numba.extending import register_jitable
    while _HELPERS:
        fn = _HELPERS.pop()
        register_jitable(cache=bool(cached and cached(fn)))(fn)


def block_equation(cls):
    """The one-line docstring: the difference equation and its reference."""
    doc = (cls.__doc__ or "").strip().splitlines()
    return doc[0] if doc else ""


__all__ = ["Block", "In", "Out", "Param", "State", "Buffer", "External", "BlockDefinitionError", "block_equation",
           "helper"]
