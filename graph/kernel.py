"""The compiler: emit ONE readable kernel module per patch, write it to the cache folder under a
hash, import it and let numba compile it (and cache the machine code beside it).

The generated `kernel(n, t0, state, live, coef, rec, ext, <buffers>, <arrays>)` runs n samples: state
and live parameters are loaded into locals before the sample loop and stored back after it; in
the loop every block's `output` then every `update` runs in schedule order, static values are
literals, buffers are power-of-two rings indexed through the shared counter `t`. The guard
(graph/guard.py) checks the records each sample and gives the kernel's return value: 0, or the
code of the first fault.

The source holds no text from a patch: only identifiers the compiler makes (slot numbers), names
of Python modules, classes and functions (each matched whole as an identifier), numbers it
formats, and comments reduced to [A-Za-z0-9_]. A file name or block name cannot become code.

The cache is verified, never trusted: each kernel has its own folder `kernel_<key>/` holding
`kernel.py`, numba's `__pycache__/` and `manifest.json` (the SHA-256 of every other file),
written after a successful compile. An entry is used only when `kernel.py` is byte for byte the
source just generated and every file matches the manifest (no file missing, none extra);
otherwise it is deleted and rebuilt. The key hashes the source, the numba, llvmlite, numpy and
Python versions, the CPU, every module that defines a function the kernel calls and every
plugin file the patch loaded.
"""
import os
import re
import sys
import time

from ..blocks.vocabulary import register_helpers
from .errors import PatchError
from .ir import KernelSourceError, ident
from .numba_start import start as start_numba
from .kcache import MANIFEST, _compile, cache_dir, kernel_key, usable_cache_dir, verified  # noqa: F401
from .program import Program

# Set by the command line (unless --quiet) to a callable taking one line of text: told when a
# kernel is compiled rather than loaded from the cache. Library code prints nothing by default.
notice = None

_DOTTED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_jitted = {}
_loaded = {}            # (cache folder, key) -> (dispatcher, path): kernels this process compiled or loaded


def dotted(name, what):
    if not isinstance(name, str) or not _DOTTED.fullmatch(name):
        raise KernelSourceError(f"{what} {name!r} is not a dotted identifier; it cannot be compiled")
    return name


def note(text, limit=60):
    """Text for a comment of the kernel: every character outside [A-Za-z0-9_] becomes `_`."""
    return "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in str(text)[:limit])


def jit(fn):
    """The numba dispatcher of a block function, made once per process.

    inline="always" makes numba splice the function into the kernel's IR instead of compiling
    and linking a module of its own: the code is the same (LLVM inlined the calls anyway), a
    cold compile takes about half as long. Block functions are not cached on their own: inlined,
    they are never compiled on their own, and a cache file beside a block's module (in
    site-packages or a plugin's folder) would be one nothing verifies.
    """
    d = _jitted.get(fn)
    if d is None:
        import numba
        start_numba()
        register_helpers()
        d = _jitted[fn] = numba.njit(fn, cache=False, inline="always")
    return d


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


def generate(prog: Program):
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
    prog.guard.emit_start(body)
    body("for i in range(n):")
    body.indent()
    body("t = t0 + i")
    for item in prog.items:
        item.emit(body)
    body.dedent()
    for bp in prog.plans:
        for node in bp.state_nodes:
            body(f"{node.load()} = {node.emit()}")
    prog.guard.emit_end(body)       # the safety check's verdict, forces zeroed or clamped
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
    e("from hapticgraph.graph.kernel import jit")
    e()
    called = {fn for item in prog.items for fn in item.functions()}
    fns = _emit_block_imports(e, prog, called)
    for fn in sorted((fn for fn in called if fn not in fns), key=lambda f: (f.__module__, f.__name__)):
        module, name = dotted(fn.__module__, "module of a step function"), ident(fn.__name__, "step function")
        e(f"from {module} import {name}")     # a @helper: numba compiles it where the kernel calls it
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


class CompiledKernel:
    """The imported, jitted kernel of a program; `run(t0, rec)` fills rec (n × records)."""

    def __init__(self, prog: Program, label=None, diagnose=True):
        import numpy as np
        start = time.perf_counter()     # numba is started where it is used: a native kernel needs none
        self.prog = prog
        source, fns = generate(prog)
        self.source = source
        self.key = kernel_key(source, fns, prog)
        self.extra = tuple(prog.buffers) + tuple(prog.arrays)

        def warm(fn):
            # compile now (or load numba's cache), so the first block of audio is not late
            fn(0, 0, prog.state, prog.live, prog.coef, np.zeros((0, len(prog.records))),
               np.zeros((0, len(prog.ext_columns))), *self.extra)
        label = label or f"kernel for {len(prog.plans)} block{'s' if len(prog.plans) != 1 else ''}"
        where = (cache_dir(), self.key)
        loaded = _loaded.get(where)
        try:
            if loaded is None:
                loaded = _loaded[where] = _compile(self.key, source, label, warm)
            else:
                warm(loaded[0])
        except Exception as exc:
            from .isolate import _is_numba_error, plugin_problems
            if not diagnose or not _is_numba_error(exc):
                raise
            # name the plugin block at fault (compiled on its own), not numba's view of the kernel
            problems = plugin_problems(prog.patch) if hasattr(prog.patch, "registry") else None
            if problems:
                raise PatchError(problems) from None
            raise
        self.fn, self.path = loaded
        if os.environ.get("HAPTICGRAPH_DUMP") == "1":
            where = self.path or "compiled in memory (no usable cache folder)"
            print(f"hapticgraph: kernel for {note(prog.patch.name)} is {where}", file=sys.stderr)
        self.compile_seconds = time.perf_counter() - start

    def run(self, t0, rec, ext):
        """Run rec.shape[0] samples from t0; the guard's code (0: sound; graph/guard.py).

        The same rec and ext as the last call (a Session's views) go straight to the machine code
        numba compiled for their types (its entry point), skipping the dispatcher's typing of
        every argument (about 0.5 µs a call; for a kernel built ahead of time, its module's
        function without the per-call type checks, done once when remembered); anything else goes through the dispatcher, which
        types it, and is remembered, when it comes twice in a row, if its types are the ones
        compiled (the Program's arrays are never rebound, so they are remembered with it)."""
        if rec is self._rec and ext is self._ext:
            return self._entry(rec.shape[0], t0, self._state, self._live, self._coef, rec, ext, *self.extra)
        p = self.prog
        code = self.fn(rec.shape[0], t0, p.state, p.live, p.coef, rec, ext, *self.extra)
        if rec is self._seen[0] and ext is self._seen[1]:
            self._remember(t0, rec, ext)
        self._seen = (rec, ext)
        return code

    _rec = _ext = None
    _seen = (None, None)

    def _remember(self, t0, rec, ext):
        """Keep the entry point compiled for exactly these arguments' types (numba's own typeof)."""
        if type(t0) is not int:     # Session's counter; numba types other numbers otherwise
            return
        p = self.prog
        args = (rec.shape[0], t0, p.state, p.live, p.coef, rec, ext) + self.extra
        try:
            if hasattr(self.fn, "fits"):        # built ahead of time (graph/aot.py): its checks, once
                if not self.fn.fits(args):
                    raise TypeError("not the built types")
                entry = self.fn.native
            else:
                sig = tuple(self.fn.typeof_pyval(a) for a in args)
                entry = self.fn.overloads[sig].entry_point
        except (KeyError, AttributeError, TypeError, ValueError):
            self._rec = self._ext = None
            return
        self._entry, self._state, self._live, self._coef = entry, p.state, p.live, p.coef
        self._rec, self._ext = rec, ext


def plugin_problems(patch):
    """Compile every plugin block of the patch on its own (graph/isolate.py); [Problem]."""
    from .isolate import plugin_problems as problems
    return problems(patch)
