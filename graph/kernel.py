"""The compiler: emit ONE readable kernel module per patch, write it to the cache folder under a
hash, import it and let numba compile it (and cache the machine code beside it).

The generated `kernel(n, t0, state, live, coef, rec, ext, <buffers>, <arrays>)` runs n samples: state
and live parameters are loaded into locals before the sample loop and stored back after it; in
the loop every block's `output` then every `update` runs in schedule order, static values are
literals, buffers are power-of-two rings indexed through the shared counter `t`.
"""
import hashlib
import importlib.util
import inspect
import math
import os
import sys
import time

from ..blocks.core import register_helpers
from .program import Program

_jitted = {}


def jit(fn, cache=True):
    """The numba dispatcher of a block function, made once per process.

    A per-sample `derive` is compiled with cache=False: its argument is a namedtuple type defined
    in one kernel module, and numba's on-disk index would point other processes at that module.
    inline="always" makes numba splice the function into the kernel's IR instead of compiling
    and linking a module of its own: the code is the same (LLVM inlined the calls anyway), a
    cold compile takes about half as long.
    """
    d = _jitted.get((fn, cache))
    if d is None:
        import numba
        register_helpers()
        d = _jitted[(fn, cache)] = numba.njit(fn, cache=cache, inline="always")
    return d


def cache_dir():
    """HAPTICGRAPH_CACHE, else the user cache directory of this platform."""
    path = os.environ.get("HAPTICGRAPH_CACHE")
    if not path:
        if sys.platform == "win32":
            base = os.environ.get("LOCALAPPDATA") or os.path.expanduser("~")
        elif sys.platform == "darwin":
            base = os.path.expanduser("~/Library/Caches")
        else:
            base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
        path = os.path.join(base, "hapticgraph")
    return path


def lit(v):
    """A Python literal for a static value (numba reads it as a compile-time constant)."""
    if isinstance(v, bool):
        return "True" if v else "False"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "math.nan"
        if math.isinf(v):
            return "math.inf" if v > 0 else "-math.inf"
        return repr(v)
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, tuple):
        return "(" + "".join(lit(float(x)) + ", " for x in v) + ")"
    raise TypeError(f"no literal for {v!r}")


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


def out_var(bp, attr):
    return f"o{bp.index}_{attr}"


def state_var(prog, slot):
    return f"s{slot}"


def generate(prog: Program):
    """The kernel module's source for a program."""
    e = Emitter()
    e(f"# hapticgraph kernel for patch {prog.patch.name!r} ({os.path.basename(prog.patch.file)}),"
      f" generated; do not edit.")
    e("# schedule: " + " -> ".join(bp.name for bp in prog.plans))
    e("import collections")
    e("import math")
    e("import numba")
    e("from hapticgraph.graph.kernel import jit")
    e()
    classes, fns = {}, []
    for bp in prog.plans:
        cls = bp.cls
        if cls not in classes:
            alias = f"{cls.type_name}_type"
            classes[cls] = alias
            module, qual = cls.__module__, cls.__qualname__
            if "<locals>" in qual:
                raise TypeError(f"block type {cls.type_name!r} must be defined at module level to be compiled")
            e(f"from {module} import {qual.split('.')[0]} as {alias}" if "." not in qual else
              f"import {module} as {alias}_module")
            if "." in qual:
                e(f"{alias} = {alias}_module.{qual}")
            for which in ("derive", "output", "update"):
                if getattr(cls, which) is not None and (which != "derive" or _needs_derive(prog, cls)):
                    e(f"{cls.type_name}_{which} = jit({alias}.{which}{', cache=False' if which == 'derive' else ''})")
                    fns.append(getattr(cls, which))
    if prog.networks:
        from ..blocks import lattice
        e("from hapticgraph.blocks.lattice import network_step, sheet_step, string_step")
        fns.append(lattice.network_step)
    for bp in prog.plans:
        if bp.coef_mode == "per_sample":
            e(f"P{bp.index} = collections.namedtuple('P{bp.index}', {list(bp.cls.params)!r})")
    e()
    buf_args = [f"b{i}" for i in range(len(prog.buffers))]
    arr_args = [f"a{i}" for i in range(len(prog.arrays))]
    e()
    e("@numba.njit(cache=True, nogil=True)")
    e(f"def kernel(n, t0, state, live, coef, rec, ext{''.join(', ' + a for a in buf_args + arr_args)}):")
    e.indent()
    for bp in prog.plans:
        for slot in bp.states:
            e(f"s{slot} = state[{slot}]")
    for bp in prog.plans:
        for name, slot in bp.live.items():
            e(f"l{slot} = live[{slot}]  # {bp.name}.{name}")
        for name, slot in bp.coef_slots.items():
            kind = "int" if isinstance(bp.coefs[name], int) and not isinstance(bp.coefs[name], bool) else (
                "bool" if isinstance(bp.coefs[name], bool) else "float")
            cast = {"int": f"int(coef[{slot}])", "bool": f"coef[{slot}] != 0.0", "float": f"coef[{slot}]"}[kind]
            e(f"c{slot} = {cast}  # {bp.name}: {name}")
    e("for i in range(n):")
    e.indent()
    e("t = t0 + i")
    for bp in prog.plans:
        if bp.cls.output is None and bp.coef_mode != "per_sample":
            continue
        e(f"# {bp.name} ({bp.cls.type_name})")
        if bp.coef_mode == "per_sample":
            args = ", ".join(expr(prog, bp, b) for b in bp.derive_args.values())
            e(f"d{bp.index} = {bp.cls.type_name}_derive(P{bp.index}({args}), {lit(prog.fs)})")
        if bp.cls.output is None:
            continue
        call = f"{bp.cls.type_name}_output({', '.join(expr(prog, bp, b) for b in bp.output_args)})"
        outs = [out_var(bp, o.attr) for o in bp.cls.outputs]
        e(f"{', '.join(outs)} = {call}")
    for k, (label, binding) in enumerate(prog.records):
        e(f"rec[i, {k}] = {expr(prog, None, binding)}  # {label}")
    for bp in prog.plans:
        if bp.cls.update is None:
            continue
        call = f"{bp.cls.type_name}_update({', '.join(expr(prog, bp, b) for b in bp.update_args)})"
        if bp.states:
            e(f"{', '.join(f's{slot}' for slot in bp.states)} = {call}  # {bp.name}")
        else:
            e(f"{call}  # {bp.name}")
    for net in prog.networks:
        e(f"# mass-spring network: {', '.join(net.net.names)} ({net.net.n} cells)")
        frc = net.slots["frc"]
        for flat, sources in net.forces.items():
            e(f"a{frc}[{flat}] += {expr(prog, None, ('sum', tuple(sources)))}")
        if net.net.stencil is None:
            for comp, col, b, inv in net.scales:
                value = expr(prog, prog.by_name[net.net.components[comp].name], b)
                e(f"a{net.slots['scale']}[{comp}, {col}] = {'1.0 / ' + value if inv else value}")
        name, args = net.step_call()
        e(f"{name}({', '.join(expr(prog, None, a) for a in args)})")
    e.dedent()
    for bp in prog.plans:
        for slot in bp.states:
            e(f"state[{slot}] = s{slot}")
    e("return 0")
    e.dedent()
    return e.source(), fns


def _needs_derive(prog, cls):
    return any(bp.cls is cls and bp.coef_mode == "per_sample" for bp in prog.plans)


def expr(prog, bp, b):
    """The kernel expression of a binding."""
    kind = b[0]
    if kind == "t":
        return "t"
    if kind == "value":
        return lit(b[1])
    if kind == "sum":
        terms = [f"a{src[1]}[{src[2]}]" if src[0] == "@" else f"ext[i, {src[1]}]" if src[0] == "#"
                 else out_var(prog.by_name[src[0]], src[1]) for src in b[1]]
        return " + ".join(terms) if terms else "0.0"
    if kind == "inv":
        return f"1.0 / {expr(prog, bp, b[1])}"
    if kind == "out":
        return out_var(prog.by_name[b[1]], b[2])
    if kind == "live":
        return f"l{b[1]}"
    if kind == "coef":
        return f"c{b[1]}"
    if kind == "dcoef":
        return f"d{bp.index}[{b[1]!r}]"
    if kind == "state":
        return f"s{b[1]}"
    if kind == "buffer":
        return f"b{b[1]}"
    if kind == "array":
        return f"a{b[1]}"
    if kind == "mask":
        return str(b[1])
    if kind == "ext":
        return f"ext[i, {b[1]}]"
    if kind == "own":
        return out_var(bp, b[1])
    raise ValueError(f"unknown binding {b!r}")


def _fingerprint(fns):
    """Hash of the modules that define the block functions a kernel calls (helpers included)."""
    h = hashlib.sha256()
    seen = set()
    for fn in fns:
        mod = sys.modules.get(fn.__module__)
        path = getattr(mod, "__file__", None)
        if path and path not in seen:
            seen.add(path)
            try:
                with open(path, "rb") as f:
                    h.update(f.read())
            except OSError:
                h.update(inspect.getsource(fn).encode())
        elif not path:
            h.update(fn.__code__.co_code)
    return h.hexdigest()


class CompiledKernel:
    """The imported, jitted kernel of a program; `run(t0, rec)` fills rec (n × records)."""

    def __init__(self, prog: Program):
        import numba
        register_helpers()
        start = time.perf_counter()
        self.prog = prog
        source, fns = generate(prog)
        key = hashlib.sha256((source + _fingerprint(fns) + numba.__version__).encode()).hexdigest()[:20]
        folder = cache_dir()
        os.makedirs(folder, exist_ok=True)
        self.path = os.path.join(folder, f"kernel_{key}.py")
        if not os.path.exists(self.path):
            tmp = f"{self.path}.{os.getpid()}.tmp"
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(source)
            os.replace(tmp, self.path)
        if os.environ.get("HAPTICGRAPH_DUMP") == "1":
            print(f"hapticgraph: kernel for {prog.patch.name!r} is {self.path}", file=sys.stderr)
        name = f"hapticgraph_kernel_{key}"
        module = sys.modules.get(name)
        if module is None:
            spec = importlib.util.spec_from_file_location(name, self.path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            sys.modules[name] = module
        self.fn = module.kernel
        self.source = source
        self.extra = tuple(prog.buffers) + tuple(prog.arrays)
        # compile now (or load numba's cache), so the first block of audio is not late
        import numpy as np
        self.run(0, np.zeros((0, len(prog.records))), np.zeros((0, len(prog.ext_columns))))
        self.compile_seconds = time.perf_counter() - start

    def run(self, t0, rec, ext):
        p = self.prog
        self.fn(rec.shape[0], t0, p.state, p.live, p.coef, rec, ext, *self.extra)
