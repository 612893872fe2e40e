"""What an exported instance computes at the host's rate when it is made (and a live parameter
when it is set): each block's `derive`, its `check`, its states' first values and its rings'
sizes, translated from the block's own Python for ONE block of the patch — the parameters that
are not live are known (a choice folds: `p.interpolation == "allpass"`), the live ones are read
from the instance, the rate is the host's.

A `derive` writes its coefficients into `coef` and returns 1 when a value the kernel holds as
structure (a literal: `whole`, a curve's choice) would change at this rate; a `check` returns 1
when it would yield a problem. Either makes `NAME_new` refuse the rate (NULL).
"""
import ast
import inspect

from ..blockplan import freeze
from ..identifiers import ident
from .source import tree_of
from .stmt import FunctionTranslator
from .values import Refused, Val, as_double, known, literal, text

LIVE, COEF = "hg_live", "hg_coef"


class Params:
    """A block's parameters as `derive` reads them: `attr(name)` a value known (not live) or read
    from the instance's live array; as an object, only the known ones (so Python can fold an
    expression over them, a generator over a list)."""

    def __init__(self, bp):
        self._bp = bp

    def attr(self, name):
        bp = self._bp
        if name in bp.live:
            return Val("f", f"{LIVE}[{bp.live[name]}]")
        if name in bp.live_sources:
            raise ValueError(f"{name!r} follows a connection (a per-sample derive)")
        if name not in bp.values:
            raise ValueError(f"no parameter {name!r}")
        return known(bp.values[name])

    def __getattr__(self, name):
        bp = self.__dict__["_bp"]
        if name in bp.live or name in bp.live_sources or name not in bp.values:
            raise AttributeError(name)
        return bp.values[name]


class Derived:
    """`return {...}` of a block's derive: each coefficient written, each structure value checked."""

    def __init__(self, bp):
        self.bp = bp

    def on_return(self, tr, node):
        if not isinstance(node.value, ast.Dict) or None in node.value.keys:
            tr.refuse("derive returns a dict literal {name: value, ...} here", node)
        bp = self.bp
        for key_node, value_node in zip(node.value.keys, node.value.values):
            key = tr.expr(key_node).known
            value = tr.expr(value_node)
            if key in bp.coef_slots:
                if not value.scalar:
                    tr.refuse(f"coefficient {key!r} is not a number", value_node)
                tr.emit(f"{COEF}[{bp.coef_slots[key]}] = {as_double(value)};")
            elif key in bp.cls.structure or key in bp.coef_arrays:
                self._same(tr, key, value, value_node)
        tr.emit("return 0;")

    def _same(self, tr, key, value, node):
        """A value held as structure (or a table): the kernel's, or this rate is refused."""
        baked = self.bp.coefs[key]
        if value.is_known:
            if freeze(value.known) != baked:
                tr.emit("return 1;")
        elif literal(baked) is None or not value.scalar:
            tr.refuse(f"{key!r} is structure or a table computed from the rate or a live parameter", node)
        else:
            tr.emit(f"if ({text(value)} != {literal(baked)}) return 1;")

    def on_yield(self, tr, node):
        tr.refuse("derive is a generator", node)

    def end(self, tr):
        tr.emit("return 0;")


class Checked:
    """A block's `check`: a problem yielded refuses the rate."""

    def on_return(self, tr, node):
        tr.emit("return 0;")

    def on_yield(self, tr, node):
        tr.emit("return 1;")

    def end(self, tr):
        tr.emit("return 0;")


class Value:
    """A lambda's value (a state's first value, a ring's size), returned; `known`: the values
    returned that were known while translating (None for one that was not)."""

    def __init__(self, kind):
        self.kind, self.known = kind, []

    def on_return(self, tr, node):
        value = tr.expr(node.value)
        if not value.scalar:
            tr.refuse("the value is not a number", node)
        self.known.append(value.known if value.is_known else None)
        tr.emit(f"return {as_double(value) if self.kind == 'f' else text(value)};")

    def on_yield(self, tr, node):
        tr.refuse("a generator", node)

    def end(self, tr):
        pass


class Row:
    """A row of a group's array computed from the rate (Group.rate_rows): the list or tuple
    returned, written into `hg_out`."""

    def on_return(self, tr, node):
        if isinstance(node.value, (ast.List, ast.Tuple)):
            items = [tr.expr(e) for e in node.value.elts]
        else:
            value = tr.expr(node.value)
            listed = value.is_known and isinstance(value.known, (list, tuple))
            items = list(value.items) if value.kind == "tuple" else [known(v) for v in value.known] if listed else None
        if items is None or not all(v.scalar for v in items):
            tr.refuse("a row of numbers is returned here (a list or a tuple)", node)
        for k, v in enumerate(items):
            tr.emit(f"hg_out[{k}] = {as_double(v)};")
        tr.emit("return;")

    def on_yield(self, tr, node):
        tr.refuse("a generator", node)

    def end(self, tr):
        pass


def _translate(lib, fn, params, mode, head):
    node = tree_of(fn)
    tr = FunctionTranslator(lib, node, fn.__code__.co_filename, fn.__globals__, params, mode)
    decls, body = tr.translate()
    return head.format(rate=tr.param_name(params[-1][0])) + "\n{\n" + "\n".join(["    " + d for d in decls] + body) + "\n}\n"


def _arguments(fn, bp, first=()):
    names = [a.arg for a in tree_of(fn).args.args]
    values = list(first) + [Val("params", known=Params(bp)), Val("f")]
    if len(names) != len(values):
        raise Refused(fn.__code__.co_filename, fn.__code__.co_firstlineno,
                      f"takes {len(names)} arguments where ({', '.join(['cls'] * len(first) + ['p', 'fs'])}) were expected")
    return list(zip(names, values))


def derive_function(lib, bp):
    """`static int hg_derive_BLOCK(live, fs, coef)`: the block's coefficients at rate fs."""
    fn = bp.cls.derive
    return _translate(lib, fn, _arguments(fn, bp), Derived(bp),
                      f"static int hg_derive_{ident(bp.ident, 'block')}(const double *{LIVE}, double {{rate}}, "
                      f"double *{COEF})")


def check_function(lib, bp, fn):
    """`static int hg_check_BLOCK(live, fs)`: 1 when the block's check yields a problem at rate fs."""
    return _translate(lib, fn, _arguments(fn, bp, (known(bp.cls),)), Checked(),
                      f"static int hg_check_{ident(bp.ident, 'block')}(const double *{LIVE}, double {{rate}})")


def value_function(lib, bp, fn, name, kind):
    """`static T NAME(live, fs)`: a lambda of the block's declarations (State, Buffer) at rate fs."""
    ctype = "double" if kind == "f" else "long long"
    return _translate(lib, fn, _arguments(fn, bp), Value(kind),
                      f"static {ctype} {name}(const double *{LIVE}, double {{rate}})")


def _bound(fn):
    """(function, the values bound before its arguments): a class method's class, known."""
    if inspect.ismethod(fn):
        return fn.__func__, [known(fn.__self__)]
    return fn, []


def _rate_arguments(fn, first):
    names = [a.arg for a in tree_of(fn).args.args]
    values = list(first) + [Val("f")]
    if len(names) != len(values):
        raise Refused(fn.__code__.co_filename, fn.__code__.co_firstlineno,
                      f"takes {len(names)} arguments where {len(values)} (the last: the rate) were expected")
    return list(zip(names, values))


def constant(lib, bp, fn):
    """The value of a lambda of the block's declarations (a ring's size) when it reads neither the
    rate nor a live parameter (the same at every rate), else None."""
    mode = Value("i")
    _translate(lib, fn, _arguments(fn, bp), mode, "static long long hg_constant(void)")
    values = set(mode.known)
    return values.pop() if len(values) == 1 and None not in values else None


def rate_function(lib, fn, name):
    """`static double NAME(double fs)`: a value of a group that is a function of the rate (Number.of_rate)."""
    fn, first = _bound(fn)
    return _translate(lib, fn, _rate_arguments(fn, first), Value("f"), f"static double {name}(double {{rate}})")


def row_function(lib, fn, args, name):
    """`static void NAME(double fs, double *hg_out)`: a row of a group's array at rate fs,
    `fn(*args, fs)` with `args` known (Group.rate_rows)."""
    fn, first = _bound(fn)
    return _translate(lib, fn, _rate_arguments(fn, first + [known(a) for a in args]), Row(),
                      f"static void {name}(double {{rate}}, double *hg_out)")


__all__ = ["COEF", "LIVE", "Params", "check_function", "constant", "derive_function", "rate_function",
           "row_function", "value_function"]
