"""The exported kernel: the very source graph/codegen.py generates for numba — every schedule item's
lines, each IR node's expression (graph/ir.py), the guard — read back and translated to one C
function, `hg_kernel(n, t0, state, live, coef, rec, ext, <buffers>, <arrays>)`, with the same
translator as the block functions it calls. The names the source imports are resolved from its
own import lines; the two that only numba has (the JIT, the flush-to-zero intrinsics) are the C
runtime's (graph/c/runtime.py)."""
import ast
import importlib
import math

from .. import codegen
from .expr import Marker, cname
from .library import Returns
from .stmt import FunctionTranslator
from .values import C_TYPES, Refused, Val, array_kind

KERNEL_FILE = "<kernel>"
# what the kernel imports from numba's side, in C
MARKERS = {"flush_enter": Marker("hg_flush_enter", "fp"), "flush_exit": Marker("hg_flush_exit", "none"),
           "jit": None}


def _resolve(expr, names):
    """A dotted name (or `jit(dotted)`) of the kernel module's header, as the object it names."""
    if isinstance(expr, ast.Call) and isinstance(expr.func, ast.Name) and expr.func.id == "jit" and len(expr.args) == 1:
        return _resolve(expr.args[0], names)
    if isinstance(expr, ast.Name):
        return names[expr.id]
    if isinstance(expr, ast.Attribute):
        return getattr(_resolve(expr.value, names), expr.attr)
    raise Refused(KERNEL_FILE, expr.lineno, f"the kernel's header line {ast.unparse(expr)!r}: not translated")


def kernel_names(tree):
    """The kernel module's names (from its import lines and `X = jit(Y.f)`) and its `def kernel`."""
    names, kernel = {"math": math}, None
    for st in tree.body:
        if isinstance(st, ast.ImportFrom):
            own = st.module in (codegen.JIT_MODULE, codegen.FPENV_MODULE)
            module = None if own else importlib.import_module(st.module)
            for alias in st.names:
                names[alias.asname or alias.name] = MARKERS[alias.name] if own else getattr(module, alias.name)
        elif isinstance(st, ast.Import):
            for alias in st.names:
                names[alias.asname or alias.name.partition(".")[0]] = importlib.import_module(
                    alias.name if alias.asname else alias.name.partition(".")[0])
        elif isinstance(st, ast.Assign) and len(st.targets) == 1 and isinstance(st.targets[0], ast.Name):
            names[st.targets[0].id] = _resolve(st.value, names)
        elif isinstance(st, ast.FunctionDef) and st.name == "kernel":
            kernel = st
    return names, kernel


def kernel_parameters(prog, node):
    """[(name, Val)] of the kernel's arguments, typed as the Program holds them."""
    names = [a.arg for a in node.args.args]
    kinds = [Val("i", nonneg=True), Val("i", nonneg=True), Val("arr"), Val("arr"), Val("arr"), Val("rec"), Val("ext")]
    kinds += [Val("arr") for _ in prog.buffer_nodes]
    try:
        kinds += [Val(array_kind(prog.arrays[ref.index])) for ref in prog.array_nodes]
    except ValueError as exc:
        raise Refused(KERNEL_FILE, node.lineno, f"the kernel takes {exc}, which C is not given") from None
    if len(names) != len(kinds):
        raise Refused(KERNEL_FILE, node.lineno, f"the kernel takes {len(names)} arguments, the program has {len(kinds)}")
    return list(zip(names, kinds))


def translate_kernel(prog, lib, fixed=frozenset()):
    """(the C definition of `hg_kernel`, its parameters) for the program. `fixed`: the indices of
    the buffers whose length is the same at every rate (their masks stay literals, as numba's)."""
    source, _ = codegen.generate(prog)
    tree = ast.parse(source, KERNEL_FILE)
    names, node = kernel_names(tree)
    if node is None:
        raise Refused(KERNEL_FILE, 1, "the generated source has no kernel")
    params = kernel_parameters(prog, node)
    returns = Returns()
    tr = FunctionTranslator(lib, node, KERNEL_FILE, names, params, returns)
    tr.unroll_inner = False                 # the sample loop: one sample after another, as numba runs it
    first = len(params) - len(prog.buffer_nodes) - len(prog.array_nodes)
    lib.fixed_rings = (tr, frozenset(cname(params[first + k][0]) for k in fixed))
    decls, body = tr.translate()
    args = ", ".join(f"{C_TYPES[v.kind]} {tr.param_name(n)}" for n, v in params)
    head = f"static long long hg_kernel({args})"
    return head + "\n{\n" + "\n".join(["    " + d for d in decls] + body) + "\n}\n", params


__all__ = ["KERNEL_FILE", "kernel_names", "kernel_parameters", "translate_kernel"]
