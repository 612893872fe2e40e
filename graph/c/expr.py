"""Python expressions in C: names, attributes, subscripts, operators and calls of the numba subset
block functions are written in. A value known while translating folds (graph/c/ops.py); any
other construct is refused with what it is, at its line."""
import ast
import builtins
import types

from . import ops
from .values import ARRAYS, NOTHING, NUMBER_ARRAYS, Refused, Val, known, text

C_RESERVED = frozenset((
    "auto break case char const continue default do double else enum extern float for goto if inline int "
    "long register restrict return short signed sizeof static struct switch typedef union unsigned void "
    "volatile while _Bool _Complex _Imaginary NAN INFINITY HUGE_VAL isfinite isnan isinf signbit "
    "fpclassify errno assert main").split())


_BUILTIN_NAMES = frozenset(dir(builtins))


def cname(name):
    """The C spelling of a Python name: itself, unless C or the runtime reserves it."""
    return f"{name}_" if name in C_RESERVED or name.startswith("hg_") else name


class Marker:
    """A function of the generated kernel's own imports that the C runtime provides (graph/c/runtime.py)."""

    def __init__(self, c, kind):
        self.c, self.kind = c, kind


class ExprTranslator:
    """Expressions of one function: `env` holds the names bound to values known while translating,
    `seed` the C variables' types ({name: [kind, nonneg]}), `cvars` those assigned so far."""

    def __init__(self, lib, file, names):
        self.lib, self.file, self.names = lib, file, names     # names: the function's globals
        self.env, self.seed, self.cvars = {}, {}, set()
        self.line = 1

    def refuse(self, message, node=None):
        raise Refused(self.file, getattr(node, "lineno", None) or self.line, message)

    def expr(self, node):
        self.line = getattr(node, "lineno", self.line)
        method = _EXPRESSIONS.get(type(node))
        if method is None:
            value = self.evaluate(node)
            if value is None:
                self.refuse(f"{type(node).__name__} ({ast.unparse(node)[:60]}) has no C translation", node)
            return value
        try:
            return method(self, node)
        except ValueError as exc:
            self.refuse(f"{ast.unparse(node)[:60]}: {exc}", node)

    # -- values known while translating -----------------------------------------------------------
    def evaluate(self, node):
        """The value Python gives `node` when every name it reads is known here (a generator over
        a parameter's list, a method of a known tuple); None otherwise."""
        bound = {t.id for c in ast.walk(node) if isinstance(c, ast.comprehension)
                 for t in ast.walk(c.target) if isinstance(t, ast.Name)}
        scope = {}
        for n in ast.walk(node):
            if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load) and n.id not in bound:
                v = self.lookup(n.id, n, strict=False)
                if v is None or not v.is_known:
                    return None
                scope[n.id] = v.known
        try:
            value = eval(compile(ast.Expression(node), self.file, "eval"), dict(self.names), scope)  # noqa: S307
        except Exception:  # noqa: BLE001 - not foldable: the caller refuses it
            return None
        return known(value)

    def lookup(self, name, node, strict=True):
        if name in self.env:
            return self.env[name]
        if name in self.cvars:
            kind, nonneg = self.seed[name]
            return Val(kind, cname(name), nonneg=nonneg)
        if name in self.names:
            return self.global_value(name, self.names[name], node)
        if name in ops.BUILTINS:
            return Val("fn", known=ops.BUILTINS[name])
        if name in _BUILTIN_NAMES and not name.startswith("_"):
            return Val("fn", known=getattr(builtins, name))      # list, tuple, ...: folded, never in C
        if strict:
            self.refuse(f"{name!r} is not defined here (a local used before it is assigned?)", node)
        return None

    def global_value(self, name, obj, node):
        if isinstance(obj, types.ModuleType):
            return Val("mod", known=obj)
        if isinstance(obj, (types.FunctionType, types.BuiltinFunctionType, Marker)):
            return Val("fn", known=obj)
        if isinstance(obj, (bool, int, float, str, tuple, frozenset)) or obj is None:
            return known(obj)
        self.refuse(f"global {name!r} ({type(obj).__name__}) cannot be read in C", node)

    # -- the expressions ------------------------------------------------------------------------
    def e_constant(self, node):
        return known(node.value)

    def e_name(self, node):
        return self.lookup(node.id, node)

    def e_attribute(self, node):
        base = self.expr(node.value)
        if base.kind == "params":
            return base.known.attr(node.attr)
        if base.kind in ARRAYS and node.attr == "shape":
            return Val(f"shape_{base.kind}", base.c)
        if base.is_known:
            try:
                obj = getattr(base.known, node.attr)
            except AttributeError:
                self.refuse(f"{ast.unparse(node)} does not exist", node)
            return Val("fn", known=obj) if callable(obj) else known(obj)
        self.refuse(f"the attribute {node.attr!r} of a {base.kind!r} value", node)

    def e_subscript(self, node):
        base = self.expr(node.value)
        if base.kind in ("rec", "ext", "arr2") and isinstance(node.slice, ast.Tuple):
            if len(node.slice.elts) != 2:
                self.refuse("two indices, [row, column]", node)
            i, c = (self.index(e) for e in node.slice.elts)
            if base.kind == "arr2":
                return Val("f", f"{base.c}.p[{self.wrap(i, base.c + '.n')} * {base.c}.m + {self.wrap(c, base.c + '.m')}]")
            return Val("f", f"{base.c}.col[{self.wrap(c, base.c + '.m')}][{self.wrap(i, base.c + '.n')}]")
        if isinstance(node.slice, ast.Slice):
            return self.slice(base, node.slice, node)
        if isinstance(node.slice, ast.Tuple):
            self.refuse("multi-dimensional indices of this value are not translated", node)
        index = self.expr(node.slice)
        if base.kind.startswith("shape_") and index.is_known:
            matrix = base.kind in ("shape_rec", "shape_ext", "shape_arr2") and index.known == 1
            return Val("i", f"{base.c}.{'m' if matrix else 'n'}", nonneg=True)
        if base.kind == "tuple" and index.is_known:
            return base.items[index.known]
        if base.is_known and index.is_known:
            return ops.fold(lambda b, k: b[k], base, index)
        if base.kind in NUMBER_ARRAYS:
            i = self.wrap(self.index(node.slice, index), base.c + ".n")
            if base.kind == "arr2":
                return Val("arr", f"hg_row({base.c}, {i})")
            return Val("f" if base.kind == "arr" else "i", f"{base.c}.p[{i}]", nonneg=base.kind == "u32arr")
        self.refuse(f"indexing a {base.kind!r} value by a value known only while running", node)

    def slice(self, base, part, node):
        """x[lo:hi] of a float array: a view (numba's and numpy's), Python's bounds."""
        if base.kind != "arr" or part.step is not None:
            self.refuse("a slice other than x[lo:hi] of a float array", node)
        lo = "0" if part.lower is None else text(self.index(part.lower))
        hi = f"{base.c}.n" if part.upper is None else text(self.index(part.upper))
        return Val("arr", f"hg_slice({base.c}, {lo}, {hi})")

    def index(self, node, value=None):
        value = self.expr(node) if value is None else value
        if value.kind not in ("i", "b"):
            self.refuse("an index must be an integer", node)
        return value

    @staticmethod
    def wrap(i, length):
        """An index, wrapped around from the end when it may be negative (numba does, as Python)."""
        return text(i) if i.nonneg else f"hg_wrap({text(i)}, {length})"

    def e_tuple(self, node):
        items = tuple(self.expr(e) for e in node.elts)
        if all(v.is_known for v in items):
            return known(tuple(v.known for v in items))
        return Val("tuple", items=items)

    def e_binop(self, node):
        return ops.binop(node.op, self.expr(node.left), self.expr(node.right))

    def e_unaryop(self, node):
        return ops.unary(node.op, self.expr(node.operand))

    def e_boolop(self, node):
        return ops.boolean(node.op, [self.expr(v) for v in node.values])

    def e_compare(self, node):
        return ops.compare(node.ops, [self.expr(node.left)] + [self.expr(c) for c in node.comparators])

    def e_ifexp(self, node):
        test = self.expr(node.test)
        if test.is_known:
            return self.expr(node.body if test.known else node.orelse)
        return ops.if_else(test, self.expr(node.body), self.expr(node.orelse))

    def e_call(self, node):
        fn = self.expr(node.func)
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args) or fn.kind != "fn":
            value = self.evaluate(node)
            if value is None:
                self.refuse(f"the call {ast.unparse(node)[:60]} (keyword or starred arguments, or not a function)",
                            node)
            return value
        obj = fn.known
        if obj is ops.BUILTINS["range"]:
            self.refuse("range() outside a for loop", node)
        args = [self.expr(a) for a in node.args]
        if isinstance(obj, Marker):
            spelled = ", ".join(text(a) if a.scalar else a.c for a in args)
            return Val(obj.kind, f"{obj.c}({spelled})")
        if obj in ops.BUILTINS.values():
            return ops.builtin(obj, args)
        if ops.is_math(obj):
            return ops.math_call(obj, args)
        if all(a.is_known for a in args):
            return ops.fold(obj, *args)
        if isinstance(obj, types.FunctionType):
            return self.lib.call(obj, args, self)
        self.refuse(f"{getattr(obj, '__name__', obj)!r} cannot be called per sample in C", node)


_EXPRESSIONS = {ast.Constant: ExprTranslator.e_constant, ast.Name: ExprTranslator.e_name,
                ast.Attribute: ExprTranslator.e_attribute, ast.Subscript: ExprTranslator.e_subscript,
                ast.Tuple: ExprTranslator.e_tuple, ast.BinOp: ExprTranslator.e_binop,
                ast.UnaryOp: ExprTranslator.e_unaryop, ast.BoolOp: ExprTranslator.e_boolop,
                ast.Compare: ExprTranslator.e_compare, ast.IfExp: ExprTranslator.e_ifexp,
                ast.Call: ExprTranslator.e_call}

__all__ = ["C_RESERVED", "ExprTranslator", "Marker", "cname", "NOTHING"]
