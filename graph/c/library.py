"""The C functions a translation calls: every Python function (a block's `output` or `update`, a
@helper, the guard's end) translated once per kind of arguments it is called with, a value known
at the call bound inside (so `if whole:` folds as numba folds a literal), and a ring's mask read
from its buffer (`line_mask` = the length of `line` − 1: a power of two the host's rate chose)."""
import re

from .source import argument_names, tree_of
from .stmt import FunctionTranslator, ends_in_return
from .values import C_TYPES, SCALARS, Refused, Val, join, known, text


class CFunction:
    """One translated function: its C `name`, `spec` ("void", a scalar kind, or a tuple of
    kinds: the values it returns through pointers), prototype and definition."""

    def __init__(self, name, spec, head, body):
        self.name, self.spec = name, spec
        self.prototype = head + ";"
        self.definition = head + "\n{\n" + "\n".join(body) + "\n}\n"


class Returns:
    """What `return` means in a per-sample function: its value, or its values through pointers."""

    def __init__(self):
        self.spec = None

    def _settle(self, tr, spec):
        old = self.spec
        if old is None:
            self.spec = spec
            return
        if (old == "void") != (spec == "void") or (isinstance(old, tuple) != isinstance(spec, tuple)) or (
                isinstance(old, tuple) and len(old) != len(spec)):
            tr.refuse("it returns values of different counts")
        new = tuple(join(a, b) for a, b in zip(old, spec)) if isinstance(old, tuple) else (
            old if old == "void" else join(old, spec))
        if new is None or (isinstance(new, tuple) and None in new):
            tr.refuse("it returns values of different types")
        if new != old:
            self.spec, tr.dirty = new, True

    def on_return(self, tr, node):
        if node.value is None:
            self._settle(tr, "void")
            return tr.emit("return;")
        value = tr.expr(node.value)
        if value.kind == "multi":
            return self._pass_on(tr, value)
        items = value.items if value.kind == "tuple" else (
            tuple(known(v) for v in value.known) if value.is_known and isinstance(value.known, tuple) else None)
        if items is None:
            if not value.scalar:
                tr.refuse(f"it returns a {value.kind!r} value", node)
            self._settle(tr, value.kind)
            return tr.emit(f"return {text(value)};")
        if not all(v.scalar for v in items):
            tr.refuse("it returns a tuple holding something other than numbers", node)
        self._settle(tr, tuple(v.kind for v in items))
        for k, v in enumerate(items):
            tr.emit(f"*hg_r{k} = {text(v)};")
        tr.emit("return;")

    def _pass_on(self, tr, value):
        """`return f(...)` of a function that returns several values: ours are its."""
        args, kinds = value.items
        self._settle(tr, kinds)
        if self.spec == kinds:
            return tr.emit(f"{value.c}({', '.join(list(args) + [f'hg_r{k}' for k in range(len(kinds))])}); return;")
        temps = [tr.fresh(k) for k in kinds]
        tr.emit(f"{value.c}({', '.join(list(args) + ['&' + t for t in temps])});")
        for k, t in enumerate(temps):
            tr.emit(f"*hg_r{k} = {t};")
        tr.emit("return;")

    def on_yield(self, tr, node):
        tr.refuse("a generator (yield) computed per sample", node)

    def end(self, tr):
        if self.spec not in (None, "void") and not ends_in_return(tr.node.body):
            tr.refuse("it may end without returning its value", tr.node)


def _masks(names, args, fixed=()):
    """Each `X_mask` argument beside a buffer argument `X` read from that buffer's length, unless
    the ring is one of `fixed` (C names of rings whose length is the same at every rate: its mask
    stays the literal numba is given)."""
    args = list(args)
    for k, name in enumerate(names[:len(args)]):
        base = name[:-5] if name.endswith("_mask") else None
        if base in names and names.index(base) < len(args):
            ring = args[names.index(base)]
            if ring.kind == "arr" and args[k].is_known and ring.c not in fixed:
                args[k] = Val("i", f"({ring.c}.n - 1)", nonneg=True)
    return args


class Library:
    """Every C function a translation needs, in the order they were made (callees first)."""

    def __init__(self):
        self.made, self.order, self.active, self.taken = {}, [], set(), set()
        # (the kernel's translator, C names of its rings of one length at every rate): see _masks
        self.fixed_rings = (None, frozenset())

    def call(self, fn, args, caller):
        """The value of calling fn (a Python function) with these values."""
        try:
            node = tree_of(fn)
        except Refused as exc:
            exc.via = exc.via + (fn,)
            raise
        try:
            names, _ = argument_names(node)
        except ValueError as exc:
            raise Refused(fn.__code__.co_filename, node.lineno, str(exc)) from None
        defaults = fn.__defaults__ or ()
        if len(args) < len(names) - len(defaults) or len(args) > len(names):
            caller.refuse(f"{fn.__qualname__}() called with {len(args)} arguments")
        missing = len(names) - len(args)
        args = list(args) + ([known(d) for d in defaults[len(defaults) - missing:]] if missing else [])
        kernel, fixed = self.fixed_rings
        args = _masks(names, args, fixed if caller is kernel else ())
        key = (fn, tuple(("known", type(a.known).__name__, repr(a.known)) if a.is_known else (a.kind, a.nonneg)
                         for a in args))
        made = self.made.get(key)
        if made is None:
            made = self._make(fn, node, names, args, key)
        spelled = [text(a) if a.scalar else a.c for a in args if not a.is_known]
        if made.spec == "void":
            return Val("none", f"{made.name}({', '.join(spelled)})")
        if isinstance(made.spec, tuple):
            return Val("multi", made.name, items=(tuple(spelled), made.spec))
        return Val(made.spec, f"{made.name}({', '.join(spelled)})")

    def _make(self, fn, node, names, args, key):
        if key in self.active:
            raise Refused(fn.__code__.co_filename, node.lineno, f"{fn.__qualname__} calls itself")
        if fn.__code__.co_freevars:
            raise Refused(fn.__code__.co_filename, node.lineno, f"{fn.__qualname__} reads variables of an enclosing function")
        self.active.add(key)
        try:
            returns = Returns()
            params = [(n, a if a.is_known else Val(a.kind, nonneg=a.nonneg)) for n, a in zip(names, args)]
            tr = FunctionTranslator(self, node, fn.__code__.co_filename, fn.__globals__, params, returns)
            decls, body = tr.translate()
        except Refused as exc:
            exc.via = exc.via + (fn,)
            raise
        finally:
            self.active.discard(key)
        made = CFunction(self._name(fn), returns.spec or "void", "", [])
        made = CFunction(made.name, made.spec, self.head(made, tr, params), ["    " + d for d in decls] + body)
        self.made[key] = made
        self.order.append(made)
        return made

    def _name(self, fn):
        base = re.sub(r"[^A-Za-z0-9_]", "_", fn.__qualname__.replace(".<locals>.", "_"))
        name, k = base, 2
        while name in self.taken:
            name, k = f"{base}_{k}", k + 1
        self.taken.add(name)
        return name

    @staticmethod
    def head(made, tr, params):
        """`static T name(args)`: a function returning several values takes a pointer for each."""
        args = [f"{C_TYPES[v.kind]} {tr.param_name(n)}" for n, v in params if not v.is_known]
        spec = made.spec
        if isinstance(spec, tuple):
            args += [f"{C_TYPES[k]} *hg_r{i}" for i, k in enumerate(spec)]
        result = C_TYPES[spec] if spec in SCALARS else "void"
        return f"static {result} {made.name}({', '.join(args) or 'void'})"

    def prototypes(self):
        return [f.prototype for f in self.order]

    def definitions(self):
        return [f.definition for f in self.order]


__all__ = ["CFunction", "Library", "Returns"]
