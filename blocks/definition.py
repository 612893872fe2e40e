"""Checks of a block type's definition, run when its class is defined (`Block.__init_subclass__`):
names, parameter defaults and ranges, the three functions' arguments and how many values they
return, read from their source (so a malformed block fails when its module is imported, not when
a user runs a patch).
"""
import ast
import functools
import inspect
import linecache
import re
import textwrap

import numpy as np


RESERVED = ("t", "fs")


class BlockDefinitionError(TypeError):
    """A block type is malformed; raised when its class is defined (module import time)."""


def arguments(fn):
    """The names of fn's arguments, in order (a block function binds them by name)."""
    return tuple(inspect.signature(fn).parameters)


def _function_tree(fn):
    """The `def` node of fn, with its file's line numbers, or None when its source cannot be read.

    Each module's source is parsed once (block modules define many functions; reading each
    one with inspect.getsource tokenizes its file again and cost a warm start tens of ms)."""
    code = getattr(fn, "__code__", None)
    if code is None:
        return None
    linecache.checkcache(code.co_filename)                 # an edited plugin is read again
    lines = linecache.getlines(code.co_filename, getattr(fn, "__globals__", None))
    defs = _module_defs(code.co_filename, "".join(lines)) if lines else {}
    for node in defs.get(code.co_firstlineno, ()):
        if node.name == code.co_name:
            return node
    try:                                                   # not found in its file: its own source
        tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    except (OSError, TypeError, SyntaxError, IndentationError):
        return None
    if not tree.body or not isinstance(tree.body[0], (ast.FunctionDef, ast.AsyncFunctionDef)):
        return None
    ast.increment_lineno(tree, code.co_firstlineno - 1)
    return tree.body[0]


@functools.lru_cache(maxsize=4)      # block types are defined module by module
def _module_defs(filename, text):
    """{first line (decorators included): [def nodes]} of a module's source."""
    try:
        tree = ast.parse(text)
    except (SyntaxError, ValueError):
        return {}
    defs, todo = {}, list(tree.body)
    while todo:       # functions at module level and in classes (ast.walk of every node costs more)
        node = todo.pop()
        if isinstance(node, ast.ClassDef):
            todo.extend(node.body)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            defs.setdefault(first, []).append(node)
    return defs


def _attributes_read(fn, argname):
    """Names `argname.X` read in fn's source: which parameters `derive` depends on."""
    tree = _function_tree(fn)
    if tree is None:
        return None
    return {node.attr for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
            and node.value.id == argname}


def check_definition(cls):
    """Raise BlockDefinitionError, naming the block type, at the first thing wrong with `cls`;
    set `cls.derive_reads` (the parameters `derive` reads)."""
    where = f"block type {cls.__name__} ({cls.type_name!r})"

    def fail(msg):
        raise BlockDefinitionError(f"{where}: {msg}")

    internal = _check_names(cls, fail)
    _check_params(cls, fail)
    _check_functions(cls, fail)
    # derive: called once with the defaults here, so a broken derive fails at import time
    coefs = _check_derive(cls, fail, internal)
    _check_returns(cls, fail)
    _check_arguments(cls, fail, set(internal) | set(coefs) | set(RESERVED))


def _check_names(cls, fail):
    """The type name, the public names and the reserved ones; the block's internal names."""
    if not re.fullmatch(r"[a-z][a-z0-9_]*", cls.type_name):
        fail("type name must be snake_case")
    public = [d.name for d in cls.inputs + cls.outputs] + list(cls.params)
    dup = {n for n in public if public.count(n) > 1}
    if dup:
        fail(f"name(s) {sorted(dup)} used for more than one port or parameter")
    for d in cls.inputs + cls.outputs:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", d.name):
            fail(f"port name {d.name!r} is not an identifier")
    internal = ([d.attr for d in cls.inputs + cls.outputs + cls.states + cls.buffers + cls.externals]
                + list(cls.params) + [b.attr + "_mask" for b in cls.buffers])
    clash = set(internal) & set(RESERVED)
    if clash:
        fail(f"{sorted(clash)} are reserved argument names")
    return internal


def _check_params(cls, fail):
    """Each parameter's default against its choices and range; only numbers are live."""
    for n, p in cls.params.items():
        if p.kind == "string" and p.choices and p.default not in p.choices:
            fail(f"parameter {n!r}: default {p.default!r} is not one of {p.choices}")
        if p.live and p.kind != "number":
            fail(f"parameter {n!r}: only float parameters can be live")
        values = list(p.default) if p.kind == "list" else [p.default]
        if p.kind in ("number", "integer", "list"):
            for v in values:
                if ((p.minimum is not None and v < p.minimum) or (p.maximum is not None and v > p.maximum)
                        or (p.above is not None and v <= p.above) or (p.below is not None and v >= p.below)):
                    fail(f"parameter {n!r}: default {p.default!r} is outside its range")


def _check_functions(cls, fail):
    """The three functions are static, and present where outputs or states need them."""
    for fname in ("derive", "output", "update"):
        fn = cls.__dict__.get(fname)
        if fn is not None and not isinstance(fn, staticmethod):
            fail(f"{fname} must be a @staticmethod")
    if cls.outputs and cls.output is None and cls.family is None:
        fail("declares outputs but no output()")
    if cls.output is not None and not cls.outputs:
        fail("defines output() but declares no Out port")
    if cls.states and cls.update is None:
        fail("declares states but no update() to advance them")


def _check_derive(cls, fail, internal):
    """derive's arguments, the parameters it reads, and its coefficients' names (it is called
    with the defaults); sets cls.derive_reads. The coefficient names."""
    cls.derive_reads = frozenset()
    coefs = ()
    if cls.derive is not None:
        if arguments(cls.derive) != ("p", "fs"):
            fail("derive must take exactly (p, fs)")
        reads = _attributes_read(cls.derive, "p")
        unknown = (reads or set()) - set(cls.params)
        if unknown:
            fail(f"derive reads unknown parameter(s) {sorted(unknown)}")
        cls.derive_reads = frozenset(reads if reads is not None else cls.params)
        try:
            coefs = tuple(cls.coefficient_names())
        except Exception as exc:  # noqa: BLE001 - reported as a definition error
            fail(f"derive fails on the default parameters: {exc!r}")
        bad = [c for c in coefs if not isinstance(c, str) or not c.isidentifier()]
        if bad:
            fail(f"derive must return a dict with identifier keys, got {bad}")
        _check_structure(cls, fail)
        clash = set(coefs) & (set(internal) | set(RESERVED))
        if clash:
            fail(f"coefficient(s) {sorted(clash)} clash with other names")
    if cls.derive is None and cls.structure:
        fail("declares structure but no derive()")
    return coefs


def _is_number(v):
    return isinstance(v, (bool, int, float, np.bool_, np.integer, np.floating))


def _check_structure(cls, fail):
    """`structure` names values derive returns; every other value is data: a number or a
    sequence of numbers (a str or None can only be structure)."""
    if isinstance(cls.structure, str) or not all(isinstance(n, str) for n in cls.structure):
        fail("structure must be a tuple of the names of derive's values")
    cls.structure = frozenset(cls.structure)
    derived = cls.derive(cls.param_tuple()(**cls.default_params()), 44100.0)
    unknown = cls.structure - set(derived)
    if unknown:
        fail(f"structure names {sorted(unknown)}, which derive does not return")
    for k, v in derived.items():
        if k in cls.structure:
            continue
        if not (_is_number(v) or (isinstance(v, (list, tuple, np.ndarray)) and all(_is_number(x) for x in v))):
            fail(f"derive's value {k!r} ({type(v).__name__}) is not a number or a list of numbers: "
                 "data must be; name it in `structure` if it is a flag or a choice")


def _check_returns(cls, fail):
    """output returns one value per output, update one per state (where the source shows it)."""
    scalars = ({d.attr for d in cls.inputs + cls.states + cls.externals} | set(RESERVED)
               | {n for n, p in cls.params.items() if p.kind in ("number", "integer", "boolean")})
    for fname, expected, what in (("output", len(cls.outputs), "output"), ("update", len(cls.states), "state")):
        fn = cls.__dict__.get(fname)
        problem = _return_count_problem(fn.__func__ if isinstance(fn, staticmethod) else fn, expected, what,
                                        scalars)
        if problem:
            fail(f"{fname}() {problem}")


def _check_arguments(cls, fail, known):
    """Every argument of output and update binds to something (output never to an output)."""
    out_attrs = {o.attr for o in cls.outputs}
    for fname in ("output", "update"):
        fn = getattr(cls, fname)
        if fn is None:
            continue
        for a in arguments(fn):
            allowed = known - out_attrs if fname == "output" else known
            if a not in allowed:
                fail(f"{fname}() argument {a!r} is not a port, parameter, state, buffer or coefficient")


_SCALAR = (ast.Constant, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare)


def _returns(fn):
    """The `return` statements of fn itself (not of functions nested in it), or None."""
    tree = _function_tree(fn)
    if tree is None:
        return None
    found, todo = [], list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.Return):
            found.append(node)
        elif not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            todo.extend(ast.iter_child_nodes(node))
    return found


def _count(value, scalars=()):
    """How many values an expression returns when that can be seen (a literal tuple: its length;
    a number, arithmetic or an argument known to be a number: 1; nothing: 0), else None."""
    if isinstance(value, ast.Name) and value.id in scalars:
        return 1
    if value is None or (isinstance(value, ast.Constant) and value.value is None):
        return 0
    if isinstance(value, ast.Tuple):
        return None if any(isinstance(e, ast.Starred) for e in value.elts) else len(value.elts)
    if isinstance(value, _SCALAR):
        return 1
    if isinstance(value, ast.IfExp):
        a, b = _count(value.body, scalars), _count(value.orelse, scalars)
        return a if a == b else (a if b is None else b if a is None else -1)
    return None


def _unassigned(fn, scalars):
    """The scalar arguments fn never rebinds (so a bare `return x` of one is one value)."""
    tree = _function_tree(fn)
    if tree is None:
        return set()
    stored = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, (ast.Store, ast.Del))}
    return set(scalars) & set(arguments(fn)) - stored


def _return_count_problem(fn, expected, what, scalars=()):
    """Why fn's returns do not give `expected` values (one per output or state), or None."""
    if fn is None or expected == 0:
        return None
    for ret in _returns(fn) or ():
        n = _count(ret.value, _unassigned(fn, scalars))
        if n is None or n == expected:
            continue
        got = ("returns nothing" if n == 0 else "returns one value" if n == 1 else
               "returns values of different counts" if n < 0 else f"returns {n} values")
        line = ret.lineno
        return (f"{got} (line {line}) but the block declares {expected} {what}{'s' if expected != 1 else ''}: "
                f"return {'one value' if expected == 1 else 'a tuple of ' + str(expected)}")
    return None
