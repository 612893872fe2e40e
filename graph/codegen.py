"""Code generation: the kernel module's source for a program (graph/program.py), written with a
small emitter. Numbers are data (the coef array); this text is the structure.

The generated `kernel(n, t0, state, live, coef, rec, ext, <buffers>, <arrays>)` runs n samples: state
and live parameters are loaded into locals before the sample loop and stored back after it; in
the loop every schedule item (graph/items.py) emits its lines in order: every block's `output`
then every `update`, the records and the guard (graph/guard.py), each fused group's step (and
after the loop, each group's end: graph/family.py). Static
values that are structure are literals, each with its name beside it; buffers are power-of-two
rings indexed through the shared counter `t`. What may reach the text at all (identifiers,
literals, comments) is graph/identifiers.py's business.
"""
import importlib.util

from . import denormals
from .identifiers import KernelSourceError, comment, dotted, ident, note
from .ir import Literal

# the module the generated kernel imports its `jit` from (the JIT backend, graph/jit.py)
JIT_MODULE = "hapticgraph.graph.jit"
FPENV_MODULE = "hapticgraph.graph.fpenv"
FLUSHES = denormals.SUPPORTED       # the kernel flushes subnormals where the interpreter does


def support_files():
    """The files of the modules the generated source imports for itself, besides the functions it
    calls (the JIT backend; graph/fpenv.py's intrinsics where it flushes): the machine code depends
    on them, so the cache key hashes them (graph/cachekey.py). Found, not imported (a warm start
    does not start numba)."""
    modules = (JIT_MODULE, FPENV_MODULE) if FLUSHES else (JIT_MODULE,)
    return [importlib.util.find_spec(m).origin for m in modules]


class Emitter:
    """Lines of Python with indentation (the whole code generator leans on this)."""

    def __init__(self):
        self.lines, self.level = [], 0

    def __call__(self, line=""):
        self.lines.append("    " * self.level + line if line else "")

    def indent(self):
        self.level += 1

    def dedent(self):
        self.level -= 1

    def source(self):
        return "\n".join(self.lines) + "\n"


def _named(node):
    return isinstance(node, Literal) and node.name


def emit_call(e, target, name, args):
    """`target = name(args)` (a bare call when `target` is empty), args being IR nodes. A line
    ends after each named Literal, with its name as a comment:

        loop_y = delay_output(loop_line, 127,  # loop: line ring mask
                t, loop_n, loop_c0, loop_c1, loop_a, loop_y1, False)  # loop: whole
    """
    lines, line = [], []
    for k, a in enumerate(args):
        line.append(a.emit())
        if _named(a) or k == len(args) - 1:
            text = ", ".join(line) + (")" if k == len(args) - 1 else ",")
            lines.append(text + (f"  # {comment(a.name)}" if _named(a) else ""))
            line = []
    head = f"{target} = {name}(" if target else f"{name}("
    if not lines:
        e(head + ")")
        return
    e(head + lines[0])
    e.indent()
    e.indent()
    for text in lines[1:]:
        e(text)
    e.dedent()
    e.dedent()


def generate(prog):
    """The kernel module's source for a program, and the Python functions it calls.

    Nothing from the patch reaches the source as text: numbers are data (the coef array), names
    are sanitized identifiers, comments carry names reduced to [A-Za-z0-9_], and module, class,
    function and parameter names (which come from Python, not from the patch) are matched whole
    as identifiers. The sample loop is the program's schedule items, in order (graph/items.py).
    """
    body = Emitter()
    args = [node.emit() for node in prog.buffer_nodes + prog.array_nodes]
    body("# compiled by hapticgraph.graph.kernel with numba.njit, nogil; cached beside this file")
    body(f"def kernel(n, t0, state, live, coef, rec, ext{''.join(', ' + a for a in args)}):")
    body.indent()
    for node in _loaded_nodes(prog):
        body(f"{node.emit()} = {node.load()}")
    if FLUSHES:
        body("fp_saved = flush_enter()      # subnormals flushed to zero, as the interpreter runs")
    prog.guard.emit_start(body)
    body("for i in range(n):")
    body.indent()
    body("t = t0 + i")
    for item in prog.items:
        item.emit(body)
    body.dedent()
    for group in prog.groups:
        group.emit_end(body)
    for bp in prog.plans:
        for node in bp.state_nodes:
            body(f"{node.load()} = {node.emit()}")
    prog.guard.emit_end(body, "verdict")     # the safety check's verdict, forces zeroed or clamped
    if FLUSHES:
        body("flush_exit(fp_saved)")
    body("return verdict")
    e = Emitter()
    e("# hapticgraph kernel, generated; do not edit. Numbers are data (coef); this text is the structure.")
    e("# schedule: " + " -> ".join(f"{note(bp.name, 30)}" for bp in prog.plans))
    fns = _emit_imports(e, prog, uses_math="math." in body.source())
    e()
    e()
    return e.source() + body.source(), fns


def _loaded_nodes(prog):
    """Scalar state, live parameters, coefficients and numbers: loaded into locals before the
    sample loop (numba keeps them in registers inside it)."""
    nodes = [node for bp in prog.plans for node in bp.state_nodes]
    for bp in prog.plans:
        nodes += list(bp.live_nodes.values()) + list(bp.coef_nodes.values())
    return nodes + prog.number_nodes


def _emit_imports(e, prog, uses_math):
    """The modules and functions the kernel uses (and only those); the functions called."""
    per_sample = [bp for bp in prog.plans if bp.coef_mode == "per_sample"]
    if per_sample:
        e("import collections")
    if uses_math:
        e("import math")
    e(f"from {JIT_MODULE} import jit")
    if FLUSHES:
        e(f"from {FPENV_MODULE} import flush_enter, flush_exit")
    e()
    called = {fn for item in prog.items for fn in item.functions()}
    fns = _emit_block_imports(e, prog, called)
    for fn in sorted((fn for fn in called if fn not in fns), key=lambda f: (f.__module__, f.__name__)):
        module, name = dotted(fn.__module__, "module of a step function"), ident(fn.__name__, "step function")
        # a @helper (a group's step): inlined where the kernel calls it, as the
        # block functions are; called, a stencil's step took 3-7 % more a sample, its arguments
        # pushed on the stack every sample (benchmarks/overhead.py, "step inlined")
        e(f"from {module} import {name}")
        e(f"{name} = jit({name})")
        fns.append(fn)
    # called once a call, after the sample loop (the guard's verdict, a group's buffers put back):
    # called, not inlined, their machine code comes from the shared cache (graph/helper_cache.py),
    # and a cold compile does not type and optimise them inside every kernel (about 0.1 s of a
    # 1,000-cell sheet's 1.5-2 s); a call costs nothing a sample
    ends = {fn for item in prog.items for fn in item.ends()} - set(fns)
    for fn in sorted(ends, key=lambda f: (f.__module__, f.__name__)):
        module, name = dotted(fn.__module__, "module of an end function"), ident(fn.__name__, "end function")
        e(f"from {module} import {name}")
        fns.append(fn)
    for bp in per_sample:
        fields = ", ".join(repr(ident(n, f"parameter of {bp.cls.type_name!r}")) for n in bp.cls.params)
        params = ident(prog.derived(bp)[1], "parameter tuple")
        e(f"{params} = collections.namedtuple('{params}', [{fields}])")
    return fns


def _emit_block_imports(e, prog, called):
    """Each block type whose functions the kernel calls, and `TYPE_output = jit(...)` for each."""
    classes, fns = set(), []
    for bp in prog.plans:
        cls = bp.cls
        which = [w for w in ("derive", "output", "update") if getattr(cls, w) is not None and getattr(cls, w) in called]
        if cls in classes or not which:
            continue
        classes.add(cls)
        tname = ident(cls.type_name, "block type name")
        alias = f"{tname}_type"
        module, qual = cls.__module__, cls.__qualname__
        if "<locals>" in qual:
            raise KernelSourceError(f"block type {tname!r} must be defined at module level to be compiled")
        dotted(module, f"module of block type {tname!r}")
        dotted(qual, f"class name of block type {tname!r}")
        if "." in qual:
            e(f"import {module} as {alias}_module")
            e(f"{alias} = {alias}_module.{qual}")
        else:
            e(f"from {module} import {qual} as {alias}")
        for w in which:
            e(f"{tname}_{w} = jit({alias}.{w})")
            fns.append(getattr(cls, w))
    return fns


def module_names(plans, built):
    """The names the kernel module defines: each block type's functions, each group's step."""
    names = {g.step()[0].__name__ for g in built}
    for bp in plans:
        t = bp.cls.type_name
        names |= {f"{t}_type", f"{t}_type_module", f"{t}_derive", f"{t}_output", f"{t}_update"}
    return names
