"""Kernels compiled ahead of time: a cached kernel loaded without importing numba.

A warm start used to import numba (about 0.25 s) and start its CPU target to load the cached
machine code (0.4 s and more). Here the kernel is compiled once by `numba.pycc` into a Python
extension module (`hapticgraph_aot` + the interpreter's extension suffix) inside the kernel's
cache entry, with `aot.json` naming the argument types it was built for. Both are files of the
entry like any other: listed in its manifest and verified byte for byte before the module is
loaded (graph/kcache.py). The module needs numpy alone.

Policy (`HAPTICGRAPH_AOT`, unset or `1`: on; `0`: numba's JIT cache, as before):
- a cold compile builds the extension module *instead of* numba's JIT cache (one numba compile
  either way, plus a link: about 0.1–0.3 s), when numba.pycc, a C compiler and Python's headers
  are there, on POSIX systems, without NUMBA_CPU_NAME / NUMBA_CPU_FEATURES (the module is built
  for this CPU). Anything missing or failing: numba's JIT cache, as before, never an error;
- numba's C runtime (helpers, reference counting), the same for every kernel, is compiled once
  per installation into `aot_runtime_<key>/` of the shared folder (graph/kcache.py's shared_dir,
  whatever kernel cache folder is used; its own manifest, verified before each link);
- a call whose arguments are not exactly the built types (int64 scalars, C-contiguous arrays of
  the same dtype, dimensions, writability and alignment: the extension module checks only the
  item size) goes to a numba dispatcher compiled for it in memory.
"""
import contextlib
import importlib.machinery
import importlib.util
import json
import operator
import os
import sys
import tempfile

import numpy as np

from .helper_cache import register as register_helpers
from .jit import warm_arguments
from .kcache import KERNEL_FILE, CacheEntry, usable_shared_dir
from .numba_start import start as start_numba
from .numba_start import wide_features

NAME = "hapticgraph_aot"
SPEC = "aot.json"
_INT64 = "int64"
_failed = []            # why building failed in this process (no compiler, no headers): not retried


def library():
    """The file name of a kernel's extension module."""
    return NAME + importlib.machinery.EXTENSION_SUFFIXES[0]


def enabled():
    return (os.environ.get("HAPTICGRAPH_AOT", "1") != "0" and os.name == "posix"
            and not os.environ.get("NUMBA_CPU_NAME") and not os.environ.get("NUMBA_CPU_FEATURES"))


# -- argument types, told without numba -------------------------------------------------------

def describe(value):
    """The JSON-able type of one kernel argument, or None if the extension module cannot take it."""
    if type(value) is int or type(value) is np.int64:
        return [_INT64]
    if type(value) is np.ndarray and value.flags.c_contiguous and value.dtype.kind in "biufc" \
            and value.dtype.isnative:
        return [value.dtype.str, value.ndim, bool(value.flags.writeable), bool(value.flags.aligned)]
    return None


_INTS = frozenset((int, np.int64))
_NDIM, _DTYPE, _FLAGS = operator.attrgetter("ndim"), operator.attrgetter("dtype"), operator.attrgetter("flags.num")
_C, _ALIGNED, _WRITEABLE = 0x1, 0x100, 0x400       # numpy's NPY_ARRAY_* bits of flags.num
_MASK = _C | _ALIGNED | _WRITEABLE


class NativeKernel:
    """The kernel of an extension module, called like the numba dispatcher it replaces. Every call
    checks its arguments in a few C-level passes (the module itself would only check item sizes:
    another number of dimensions or a strided array would be read out of bounds); a call that
    does not fit goes to `jit()`'s numba dispatcher."""

    def __init__(self, native, kinds, jit):
        self.ints = sum(1 for k in kinds if k == [_INT64])
        arrays = kinds[self.ints:]
        if any(k == [_INT64] for k in arrays):
            raise ValueError("the integers come first")
        self.count = len(kinds)
        self.types = (np.ndarray,) * len(arrays)
        self.ndims = tuple(int(k[1]) for k in arrays)
        self.dtypes = tuple(np.dtype(k[0]) for k in arrays)
        self.flags = tuple(_C | (_WRITEABLE if k[2] else 0) | (_ALIGNED if k[3] else 0) for k in arrays)
        self.native, self.jit, self.dispatcher = native, jit, None

    def fits(self, args):
        """True if every argument is exactly of the type the module was built for."""
        k = self.ints
        arrays = args[k:]
        return (len(args) == self.count and _INTS.issuperset(map(type, args[:k]))
                and tuple(map(type, arrays)) == self.types and tuple(map(_NDIM, arrays)) == self.ndims
                and tuple(map(_MASK.__and__, map(_FLAGS, arrays))) == self.flags
                and tuple(map(_DTYPE, arrays)) == self.dtypes)

    def __call__(self, *args):
        if self.fits(args):
            return self.native(*args)
        if self.dispatcher is None:
            self.dispatcher = self.jit()
        return self.dispatcher(*args)


# -- loading ----------------------------------------------------------------------------------

def load(folder, jit):
    """The NativeKernel of a verified folder (a cache entry, or one being written), or None when
    the folder holds no extension module or it cannot be loaded. `jit()` makes the fallback."""
    path = os.path.join(folder, library())
    try:
        with open(os.path.join(folder, SPEC), "rb") as f:
            spec = json.loads(f.read(1 << 16))
        kinds = spec["args"]
        if spec.get("module") != NAME or not isinstance(kinds, list) or not os.path.isfile(path):
            return None
        fn = NativeKernel(None, kinds, jit)         # the types read before the module is loaded
        loader = importlib.machinery.ExtensionFileLoader(NAME, path)
        module = importlib.util.module_from_spec(importlib.util.spec_from_file_location(NAME, path, loader=loader))
        loader.exec_module(module)
        fn.native = module.kernel
        return fn
    except (OSError, ImportError, ValueError, KeyError, TypeError, IndexError, AttributeError):
        return None


# -- building ---------------------------------------------------------------------------------

def build(folder, kernel, args, root, say):
    """Compile `kernel` for these arguments into `folder` (the extension module and aot.json);
    True if done. Never raises for a missing tool: False, and numba's JIT is used instead."""
    if not enabled() or _failed:
        return False
    kinds = [describe(a) for a in args]
    try:
        NativeKernel(None, kinds, None)
    except (TypeError, ValueError):     # an argument it cannot take (None), or not integers first
        return False
    try:
        _module(kernel, args, folder, lambda: _runtime(root, say))
    except Exception as exc:        # noqa: BLE001 — any failure means: use numba's JIT
        for name in (library(), SPEC):
            with contextlib.suppress(OSError):
                os.remove(os.path.join(folder, name))
        if isinstance(exc, _ToolchainError):
            _failed.append(exc)
            say(f"kernels are not built ahead of time ({exc}); numba loads them")
        return False
    with open(os.path.join(folder, SPEC), "w", encoding="utf-8") as f:
        json.dump({"module": NAME, "args": kinds}, f)
    return True


def native(folder, kernel, args, root, say, jit):
    """Build the extension module into folder (one being written) and load it: a NativeKernel,
    or None (and nothing of it left in folder) when it cannot be built or loaded."""
    if not build(folder, kernel, args, root, say):
        return None
    fn = load(folder, jit)
    if fn is None:
        for name in (library(), SPEC):
            with contextlib.suppress(OSError):
                os.remove(os.path.join(folder, name))
    return fn


class _ToolchainError(Exception):
    """numba.pycc, the C compiler or Python's headers are missing or failed."""


def _tail(log):
    try:
        log.seek(0)
        lines = [ln.strip() for ln in log.read().decode("utf-8", "replace").splitlines() if ln.strip()]
    except (OSError, ValueError):
        return ""
    return f": {lines[-1][:200]}" if lines else ""


@contextlib.contextmanager
def _tool(what):
    """Runs the C compiler or linker, its output (written to this process's stdout and stderr)
    kept in a file; a failure becomes a _ToolchainError naming what failed and its last line."""
    with tempfile.TemporaryFile() as log:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(log.fileno(), 1)
            os.dup2(log.fileno(), 2)
            yield
        except Exception as exc:    # noqa: BLE001 — distutils' CompileError, LinkError, a missing tool
            failed = exc
        else:
            failed = None
        finally:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        if failed is not None:
            raise _ToolchainError(f"{what}: {type(failed).__name__}{_tail(log)}") from failed


@contextlib.contextmanager
def _patched(obj, name, value):
    old = getattr(obj, name)
    setattr(obj, name, value)
    try:
        yield
    finally:
        setattr(obj, name, old)


def _cc():
    """numba.pycc's CC for NAME, its compiler check left to the first compile (numba's check
    leaves two temporary folders behind each time)."""
    import warnings
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # pycc is "pending deprecation": without it, numba's JIT
            from numba.pycc import CC, platform
        with _patched(platform, "external_compiler_works", lambda: True):
            cc = CC(NAME)
    except Exception as exc:        # noqa: BLE001 — no setuptools, no pycc in this numba
        raise _ToolchainError(f"numba.pycc: {type(exc).__name__}: {exc}") from exc
    cc.target_cpu = "host"
    return cc


def _nogil(flags_class):
    class Flags(flags_class):
        """numba's flags for a pycc export, with the GIL released while the kernel runs (as the
        JIT kernel's nogil=True): the audio callback and the main thread run side by side."""

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.release_gil = True
    return Flags


_PLAIN = (type(None), bool, int, float, complex, str, bytes)


def _plain(obj):
    """True if obj unpickles with the standard library alone (the module unpickles its constants
    when it is imported: anything else would import numba, or a plugin's module, then)."""
    if type(obj) in _PLAIN:
        return True
    if type(obj) in (tuple, list):
        return all(_plain(o) for o in obj)
    return isinstance(obj, type) and issubclass(obj, BaseException) and obj.__module__ == "builtins"


def _module(kernel, args, folder, runtime):
    """numba compiles the kernel for these arguments into an object file, linked with `runtime()`
    (asked for after the compile: a kernel numba cannot compile does not build it) into the
    extension module in folder."""
    cc = _cc()                  # first: it imports numba.pycc, quietly
    import numba
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.codegen import AOTCPUCodegen
    from numba.pycc import compiler
    start_numba()
    register_helpers()
    cc.export("kernel", numba.types.int64(*(numba.typeof(a) for a in args)))(kernel)
    with tempfile.TemporaryDirectory(prefix="hapticgraph-aot-") as build:
        obj = os.path.join(build, "kernel.o")
        with _patched(AOTCPUCodegen, "_customize_tm_features", _wide_aot_features):
            mc = compiler.ModuleCompiler(cc._export_entries, NAME, True, cpu_name="host")
        mc.external_init_function = cc._init_function
        with global_compiler_lock, _patched(compiler, "Flags", _nogil(compiler.Flags)):
            mc.write_native_object(obj, wrap=True)
        envs = list(mc.function_environments.values()) + list(mc.extra_environments.values())
        if not all(_plain(env.consts) for env in envs):
            raise ValueError("the kernel's constants need more than the standard library")
        tools = cc._toolchain
        objects = [obj] + runtime()
        with _tool("linking"):
            tools.link_shared(os.path.join(folder, library()), objects, tools.get_python_libraries(),
                              tools.get_python_library_dirs(), export_symbols=mc.dll_exports,
                              extra_ldflags=cc._get_extra_ldflags())


def _wide_aot_features(codegen):
    """The ahead-of-time target's features: its CPU model's, with the widest vectors allowed
    (numba_start.WIDE_VECTORS), as the JIT target has them."""
    import llvmlite.binding as llvm
    return wide_features(llvm.get_host_cpu_features().flatten())


def _runtime_key():
    import hashlib
    import sysconfig

    import numba
    parts = [NAME, numba.__version__, np.__version__, sys.version, sys.platform, library(),
             str(sysconfig.get_config_var("CC")), os.environ.get("CC", ""), os.environ.get("CFLAGS", "")]
    return hashlib.sha256("\0".join(parts).encode("utf-8", "surrogatepass")).hexdigest()[:24]


def _objects(folder):
    return sorted(os.path.join(folder, n) for n in os.listdir(folder) if n.endswith((".o", ".obj")))


def _runtime(root, say):
    """The object files of numba's C runtime for extension modules named NAME: compiled once per
    installation into aot_runtime_<key>/ of the shared folder (else of the kernel cache folder
    `root`), verified against its manifest before every link."""
    import shutil
    entry = CacheEntry(usable_shared_dir(root), _runtime_key(), prefix="aot_runtime")
    if not entry.verify():
        say("compiling numba's C runtime for native kernels (once per installation)…")
        cc = _cc()
        with entry.fresh() as tmp:
            with _tool("the C compiler"):
                objects = cc._compile_mixins(os.path.join(tmp, "build"))
            names = [os.path.basename(o) for o in objects]
            if len(set(names)) != len(names):
                raise _ToolchainError("numba's runtime sources share a name")
            for obj in objects:
                os.replace(obj, os.path.join(tmp, os.path.basename(obj)))
            shutil.rmtree(os.path.join(tmp, "build"))
            entry.commit(tmp)
        if not entry.verify():
            raise OSError(f"{entry.path}: not as written")
    return _objects(entry.path)


class AotBackend:
    """Kernels built ahead of time into an extension module (the backend protocol: graph/jit.py).
    `jit` (the JIT backend) compiles in memory for arguments the module was not built for; `say`
    tells what is being compiled."""

    name = "aot"

    def __init__(self, root, say, jit):
        self.root, self.say, self.jit = root, say, jit

    def _fallback(self, code, filename):
        def make():
            self.say("compiling the kernel with numba for arguments of other types…")
            return self.jit.memory(code, filename=filename, reuse=True)
        return make

    def load(self, entry, code, warm):
        fn = load(entry.path, self._fallback(code, entry.kernel_file))
        if fn is not None:
            warm(fn)
        return fn

    def build(self, folder, code, warm):
        path = os.path.join(folder, KERNEL_FILE)
        fn = native(folder, code.module(path).kernel, warm_arguments(warm), self.root, self.say,
                    self._fallback(code, path))
        if fn is not None:
            warm(fn)
        return fn

    def entry_point(self, fn, args):
        return fn.native if fn.fits(args) else None
