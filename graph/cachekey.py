"""The key that names a kernel's cache entry: a hash of everything its machine code depends on
(the source, the numba, llvmlite, numpy and Python versions, the CPU, every module that defines a
function the kernel calls, every plugin file the patch loaded). Part of the cache (graph/kcache.py)."""
import hashlib
import inspect
import os
import platform
import sys
from importlib import metadata

from .numba_start import WIDE_VECTORS

# numba's settings that change the machine code it makes (numba's own cache index does not name
# the optimisation ones): a kernel or helper compiled under one is not the code of another
CODEGEN_SETTINGS = ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_OPT", "NUMBA_LOOP_VECTORIZE",
                    "NUMBA_SLP_VECTORIZE", "NUMBA_ENABLE_AVX", "NUMBA_BOUNDSCHECK")

_SKIP_TOP = {"numpy", "numba", "llvmlite", "builtins"} | set(getattr(sys, "stdlib_module_names", ()))
_host = []
# the lines of /proc/cpuinfo that say which instructions the machine code may use
_CPU_FIELDS = {"vendor_id", "cpu family", "model", "model name", "flags", "Features", "CPU implementer",
               "CPU architecture", "CPU variant", "CPU part", "isa"}


def _cpu():
    """The CPU the machine code is made for. Linux says it in /proc/cpuinfo (a warm start reads
    that instead of loading LLVM, 70 ms); elsewhere, LLVM's name and features of the host."""
    if sys.platform.startswith("linux"):
        try:
            with open("/proc/cpuinfo", "rb") as f:
                first = f.read(1 << 16).decode("utf-8", "replace").split("\n\n")[0]
        except OSError:
            first = ""
        lines = [ln for ln in first.splitlines() if ln.split(":")[0].strip() in _CPU_FIELDS]
        if lines:
            return "\n".join(lines)
    from llvmlite import binding
    return f"{binding.get_host_cpu_name()} {binding.get_host_cpu_features().flatten()}"


def dist_version(dist):
    """The installed version of the distribution `dist`, or '?'."""
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "?"


def host_id():
    """Versions, the CPU the machine code is made for and numba's code-generation settings
    (CODEGEN_SETTINGS), told without importing numba (a warm start loads an extension module and
    never imports it: graph/aot.py)."""
    if not _host:
        import numpy
        _host.append("\0".join([dist_version("numba"), dist_version("llvmlite"), numpy.__version__, sys.version,
                                sys.implementation.cache_tag or "", platform.machine(), _cpu(),
                                *(os.environ.get(name, "") for name in CODEGEN_SETTINGS), WIDE_VECTORS]))
    return _host[0]


def _codes(code):
    yield code
    for c in code.co_consts:
        if inspect.iscode(c):
            yield from _codes(c)


def _reached(fn, todo):
    """What fn's code names through its globals: functions and dispatchers (and, of a module it
    names, the attributes it reads), outside the standard library and numpy/numba."""
    g = fn.__globals__
    for code in _codes(fn.__code__):
        for name in code.co_names:
            value = g.get(name)
            if inspect.ismodule(value):
                if value.__name__.split(".")[0] not in _SKIP_TOP:
                    todo += [getattr(value, attr, None) for attr in code.co_names]
            elif value is not None:
                todo.append(value)


def reachable_files(fns):
    """Source files of every function the kernel calls and of every function (a @helper, a
    dispatcher) those reach through their globals, outside the standard library and numpy/numba;
    plus the bytecode of functions that have no file."""
    files, seen, todo = set(), set(), list(fns)
    anonymous = []
    while todo:
        fn = todo.pop()
        fn = getattr(fn, "py_func", fn)          # a numba dispatcher: its Python function
        if not inspect.isfunction(fn) or fn in seen:
            continue
        seen.add(fn)
        if (fn.__module__ or "").split(".")[0] in _SKIP_TOP:
            continue
        path = getattr(sys.modules.get(fn.__module__), "__file__", None)
        if path:
            files.add(os.path.realpath(path))
        else:
            anonymous.append(fn.__code__.co_code)
        _reached(fn, todo)
    return files, anonymous


def file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def kernel_key(source, fns, files=()):
    """The hash that names a kernel's cache entry: its source, the host, the files of `fns` (the
    functions it calls, and the code generator's `jit`) and `files` (the plugin files the patch
    loaded, the modules the source imports for itself: graph/codegen.support_files)."""
    h = hashlib.sha256()

    def add(text):
        h.update(str(text).encode("utf-8", "surrogatepass"))
        h.update(b"\0")
    add("hapticgraph kernel 3")
    add(source)
    add(host_id())
    reached, anonymous = reachable_files(fns)
    reached |= {os.path.realpath(p) for p in files}
    for path in sorted(reached):
        add(path)
        try:
            add(file_digest(path))
        except OSError as exc:
            add(f"unreadable: {exc}")
    for code in anonymous:
        add(hashlib.sha256(code).hexdigest())
    return h.hexdigest()[:24]
