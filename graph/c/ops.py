"""Operators, builtins and math functions in C with Python's meaning (numba's, which is the same
for the numbers blocks compute with): true division always in double, `//` and `%` floored (the
C library's fmod and integer division truncate: graph/c/runtime.py's hg_ helpers floor), `min`
and `max` returning their first argument on a tie, `round` half to even, `int` truncating.

Every function here takes values (graph/c/values.py) and returns one, or raises ValueError with
what is refused (the translator adds the file and line). Values known while translating are
folded by Python itself, so a folded constant is the very number Python computes.
"""
import ast
import builtins
import math
import operator

from .values import NUMBER_ARRAYS, SCALARS, Val, as_double, known, literal, text

_FOLD = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
         ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow,
         ast.BitAnd: operator.and_, ast.BitOr: operator.or_, ast.BitXor: operator.xor,
         ast.LShift: operator.lshift, ast.RShift: operator.rshift,
         ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
         ast.Gt: operator.gt, ast.GtE: operator.ge, ast.Is: operator.is_, ast.IsNot: operator.is_not,
         ast.In: lambda a, b: a in b, ast.NotIn: lambda a, b: a not in b,
         ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Not: operator.not_, ast.Invert: operator.invert}
_C = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.BitAnd: "&", ast.BitOr: "|", ast.BitXor: "^",
      ast.LShift: "<<", ast.RShift: ">>", ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=",
      ast.Gt: ">", ast.GtE: ">="}

# math functions: name in C, and whether the result is an integer (Python's floor and ceil are)
MATH = {math.sin: "sin", math.cos: "cos", math.tan: "tan", math.asin: "asin", math.acos: "acos",
        math.atan: "atan", math.sinh: "sinh", math.cosh: "cosh", math.tanh: "tanh", math.exp: "exp",
        math.expm1: "expm1", math.log10: "log10", math.log2: "log2", math.log1p: "log1p",
        math.sqrt: "sqrt", math.fabs: "fabs", math.atan2: "atan2", math.pow: "pow", math.fmod: "fmod",
        math.copysign: "copysign", math.hypot: "hypot", math.log: "log"}
MATH_INT = {math.floor: "floor", math.ceil: "ceil", math.trunc: "trunc"}
MATH_FLAG = {math.isfinite: "isfinite", math.isnan: "isnan", math.isinf: "isinf"}


def fold(fn, *values):
    """fn applied by Python to known values; ValueError if Python refuses (0 / 0, ...)."""
    try:
        return known(fn(*(v.known for v in values)))
    except Exception as exc:  # noqa: BLE001 - reported at the source line
        raise ValueError(f"Python refuses this with the values it has here: {exc!r}") from None


def _scalars(op, *values):
    for v in values:
        if not v.scalar:
            raise ValueError(f"{op} of a {v.kind!r} value: only numbers and flags")


def _number(a, b):
    """The type of a + b: integers unless either is a double (flags count as integers)."""
    return "f" if "f" in (a.kind, b.kind) else "i"


def binop(op, a, b):
    """a op b."""
    kind = type(op)
    if a.is_known and b.is_known:
        return fold(_FOLD[kind], a, b)
    _scalars(type(op).__name__, a, b)
    if kind in (ast.Add, ast.Sub, ast.Mult):
        nonneg = kind is not ast.Sub and a.nonneg and b.nonneg
        return Val(_number(a, b), f"({text(a)} {_C[kind]} {text(b)})", nonneg=nonneg)
    if kind is ast.Div:
        return Val("f", f"({as_double(a)} / {as_double(b)})")
    if kind in (ast.FloorDiv, ast.Mod):
        helper = "hg_floordiv" if kind is ast.FloorDiv else "hg_mod"
        if _number(a, b) == "i":
            positive = b.is_known and b.known > 0
            return Val("i", f"{helper}_i({text(a)}, {text(b)})", nonneg=positive and (kind is ast.Mod or a.nonneg))
        return Val("f", f"{helper}({as_double(a)}, {as_double(b)})")
    if kind is ast.Pow:
        if _number(a, b) == "i":
            raise ValueError("an integer power of an integer computed per sample (write it with floats)")
        return power(a, b)
    if kind in (ast.BitAnd, ast.BitOr, ast.BitXor, ast.LShift, ast.RShift):
        if "f" in (a.kind, b.kind):
            raise ValueError("a bitwise operator on a float")
        flag = a.kind == b.kind == "b" and kind in (ast.BitAnd, ast.BitOr, ast.BitXor)
        nonneg = flag or (a.nonneg or b.nonneg if kind is ast.BitAnd else a.nonneg and b.nonneg)
        return Val("b" if flag else "i", f"({text(a)} {_C[kind]} {text(b)})", nonneg=nonneg)
    raise ValueError(f"the operator {kind.__name__}")


def unary(op, v):
    kind = type(op)
    if v.is_known:
        return fold(_FOLD[kind], v)
    _scalars(kind.__name__, v)
    if kind is ast.Not:
        return Val("b", f"(!{text(v)})", nonneg=True)
    if kind is ast.USub:
        return Val("f" if v.kind == "f" else "i", f"(-{text(v)})")
    if kind is ast.UAdd:
        return Val("f" if v.kind == "f" else "i", text(v), nonneg=v.nonneg)
    if v.kind == "f":
        raise ValueError("~ of a float")
    return Val("i", f"(~{text(v)})")


def compare(ops, values):
    """a < b < c ...: each pair compared once, joined by && (operands are pure C expressions)."""
    if all(v.is_known for v in values):
        try:
            ok = all(_FOLD[type(op)](a.known, b.known) for op, a, b in zip(ops, values, values[1:]))
        except Exception as exc:  # noqa: BLE001
            raise ValueError(f"Python refuses this comparison: {exc!r}") from None
        return known(bool(ok))
    parts = []
    for op, a, b in zip(ops, values, values[1:]):
        if type(op) not in _C:
            raise ValueError(f"the comparison {type(op).__name__} on values known only while running")
        _scalars("a comparison", a, b)
        parts.append(f"({text(a)} {_C[type(op)]} {text(b)})")
    return Val("b", parts[0] if len(parts) == 1 else "(" + " && ".join(parts) + ")", nonneg=True)


def truth(v):
    """C text of a value's truth (a double's NaN is true, as in Python)."""
    if v.is_known:
        return "1" if v.known else "0"
    _scalars("a truth test", v)
    return text(v)


def condition(v):
    """C text of an `if`'s or a `while`'s test: its truth without an outer pair of parentheses that
    wraps it whole (`if (x == 0)`: clang warns of `if ((x == 0))` as of a mistyped assignment)."""
    c = truth(v)
    if not (c.startswith("(") and c.endswith(")")) or '"' in c or "'" in c:
        return c
    depth = 0
    for k, ch in enumerate(c):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if depth == 0:
            return c[1:-1] if k == len(c) - 1 else c
    return c


def boolean(op, values):
    """a and b / a or b of flags (Python gives back an operand: of numbers that is refused)."""
    is_and = isinstance(op, ast.And)
    kept = []
    for v in values:
        if v.is_known:
            if bool(v.known) != is_and:       # a known false `and`, a known true `or`: decided
                return v if not kept else Val("b", "(" + f" {'&&' if is_and else '||'} ".join(kept + [truth(v)]) + ")")
            continue
        if v.kind != "b":
            raise ValueError("`and`/`or` of numbers (Python gives back one of them): compare them first")
        kept.append(text(v))
    if not kept:
        return values[-1]
    return Val("b", kept[0] if len(kept) == 1 else "(" + f" {'&&' if is_and else '||'} ".join(kept) + ")",
               nonneg=True)


def if_else(test, a, b):
    if test.is_known:
        return a if test.known else b
    _scalars("a conditional expression", a, b)
    kind = a.kind if a.kind == b.kind else _number(a, b)
    ta, tb = (as_double(a), as_double(b)) if kind == "f" else (text(a), text(b))
    return Val(kind, f"({truth(test)} ? {ta} : {tb})", nonneg=a.nonneg and b.nonneg)


def builtin(fn, args):
    """int, float, bool, abs, min, max, round, len of values."""
    if all(a.is_known for a in args):
        return fold(fn, *args)
    if fn is len:
        if args[0].kind in NUMBER_ARRAYS:
            return Val("i", f"{args[0].c}.n", nonneg=True)
        raise ValueError(f"len() of a {args[0].kind!r} value")
    _scalars(fn.__name__, *args)
    v = args[0]
    if fn is int:
        return Val("i", f"((long long){text(v)})" if v.kind == "f" else text(v), nonneg=v.nonneg)
    if fn is float:
        return Val("f", as_double(v))
    if fn is bool:
        return Val("b", f"({text(v)} != 0)", nonneg=True)
    if fn is abs:
        return Val(v.kind if v.kind == "f" else "i", f"fabs({text(v)})" if v.kind == "f" else f"llabs({text(v)})",
                   nonneg=v.kind != "f")
    if fn is round and len(args) == 1:
        return Val("i", f"((long long)nearbyint({as_double(v)}))")
    if fn in (min, max) and len(args) >= 2:
        return _minmax(fn, args)
    raise ValueError(f"{fn.__name__}() with these arguments")


def _minmax(fn, args):
    """Python's min/max: the first argument unless a later one is strictly smaller/larger."""
    kind = "f" if any(a.kind == "f" for a in args) else "i"
    name = f"hg_{fn.__name__}{'' if kind == 'f' else '_i'}"
    acc = as_double(args[0]) if kind == "f" else text(args[0])
    for a in args[1:]:
        acc = f"{name}({acc}, {as_double(a) if kind == 'f' else text(a)})"
    nonneg = all(a.nonneg for a in args) if fn is min else any(a.nonneg for a in args)
    return Val(kind, acc, nonneg=nonneg and kind == "i")


def power(a, b):
    """`a ** b` or math.pow(a, b) of floats as numba computes it: LLVM rewrites a power of a known
    base 2.0 ** n (n a whole number but 0) as exp2(n·b), and of a known exponent 0.5, 2.0, 1.0,
    −1.0 as sqrt (its −0 and −∞ as pow's), a·a, a, 1/a. Those round otherwise than the library's
    pow on about 1 argument in 1,000 (glibc: 2.0 ** b on 20 of 20,000, b ** 2.0 on 16)."""
    x, y = as_double(a), as_double(b)
    if a.is_known and float(a.known) > 0.0:
        mantissa, exponent = math.frexp(float(a.known))
        if mantissa == 0.5 and exponent != 1:
            n = exponent - 1
            return Val("f", f"exp2({y})" if n == 1 else f"exp2({literal(float(n))} * {y})")
    if b.is_known and float(b.known) in (0.5, 2.0, 1.0, -1.0):
        return Val("f", {0.5: f"({x} == -INFINITY ? INFINITY : fabs(sqrt({x})))", 2.0: f"({x} * {x})",
                         1.0: f"(+{x})", -1.0: f"(1.0 / {x})"}[float(b.known)])
    return Val("f", f"pow({x}, {y})")


def math_call(fn, args):
    """A function of the math module."""
    if all(a.is_known for a in args):
        return fold(fn, *args)
    _scalars(fn.__name__, *args)
    if fn is math.pow:
        return power(*args)
    spelled = ", ".join(as_double(a) for a in args)
    if fn in MATH_INT:
        return Val("i", f"((long long){MATH_INT[fn]}({spelled}))")
    if fn in MATH_FLAG:
        return Val("b", f"({MATH_FLAG[fn]}({spelled}) != 0)", nonneg=True)
    if fn in MATH and (fn is not math.log or len(args) == 1):
        return Val("f", f"{MATH[fn]}({spelled})")
    raise ValueError(f"math.{fn.__name__} with {len(args)} argument(s)")


BUILTINS = {name: getattr(builtins, name) for name in ("int", "float", "bool", "abs", "min", "max", "round", "len",
                                                       "range")}


def is_math(fn):
    return fn in MATH or fn in MATH_INT or fn in MATH_FLAG


__all__ = ["BUILTINS", "binop", "boolean", "builtin", "compare", "condition", "fold", "if_else", "is_math", "math_call", "truth",
           "unary", "SCALARS"]
