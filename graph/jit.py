"""The JIT backend: numba compiles the kernel module when it is loaded, its machine code cached by
numba in the entry's `__pycache__/`; also `jit`, the dispatcher of a block function the generated
kernel calls (`TYPE_output = jit(TYPE.output)`), and the kernel module made from its source.

A backend (this one, graph/aot.py) offers, for the orchestration in graph/kernel.py:
    load(entry, code, warm)     the kernel from a verified cache entry, or None if it holds none
                                of this backend's; warmed (compiled now, or its cache loaded)
    build(folder, code, warm)   the kernel compiled into a fresh entry folder, or None if this
                                backend cannot build it here (the next one is tried)
    entry_point(fn, args)       the machine code of fn for exactly these arguments (called without
                                the dispatcher's typing), or None
`code` is a KernelCode, `warm(fn)` calls fn once with the arguments it is compiled for.
"""
import os
import sys
import types

from .helper_cache import register as register_helpers
from .kcache import KERNEL_FILE
from .numba_start import start as start_numba

_jitted = {}
_cache_class = []


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


class KernelCode:
    """A kernel's source and key, and its module (executed from the source in memory when first
    asked for: executing it jits the block functions, so a kernel loaded ahead of time never does)."""

    def __init__(self, key, source):
        self.key, self.source = key, source
        self.name = f"hapticgraph_kernel_{key}"

    def module(self, filename, reuse=False):
        """The kernel module made from the source (no .pyc is written or read), its `__file__`
        `filename` (numba's cache goes beside it); with `reuse`, the one made before, if any."""
        module = sys.modules.get(self.name) if reuse else None
        if module is not None:
            return module
        module = types.ModuleType(self.name)
        module.__file__ = filename
        sys.modules[self.name] = module   # numba re-imports it by name when it loads cached code
        try:
            exec(compile(self.source, filename, "exec"), module.__dict__)
        except BaseException:
            self.forget()
            raise
        return module

    def forget(self):
        sys.modules.pop(self.name, None)


def warm_arguments(warm):
    """The arguments `warm` calls the kernel with (those it is compiled for)."""
    got = []
    warm(lambda *args: got.append(args))
    return got[0]


def _pinned_cache(py_func):
    """numba's function cache, kept in `__pycache__` beside the kernel file whatever
    NUMBA_CACHE_DIR or numba's fallback locations say, so every file it reads is one we verify."""
    if not _cache_class:
        from numba.core import caching

        class Locator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
            def __init__(self, py_func, py_file):
                self._py_func, self._py_file = py_func, py_file
                self._lineno = py_func.__code__.co_firstlineno

            def get_cache_path(self):
                return os.path.join(os.path.dirname(self._py_file), "__pycache__")

        class Impl(caching.CompileResultCacheImpl):
            def __init__(self, py_func):
                self._lineno = py_func.__code__.co_firstlineno
                self._locator = Locator(py_func, py_func.__code__.co_filename)
                self._filename_base = self.get_filename_base(f"kernel.{py_func.__qualname__}",
                                                             getattr(sys, "abiflags", ""))

        class Cache(caching.FunctionCache):
            _impl_class = Impl
        _cache_class.append(Cache)
    return _cache_class[0](py_func)


def dispatcher(module, cached):
    """numba's dispatcher of the kernel module's `kernel` (nogil), its cache pinned beside the
    module's file when `cached`."""
    import numba
    start_numba()
    register_helpers()      # the @helper functions defined since the last compile
    fn = numba.njit(nogil=True)(module.kernel)
    if cached:
        fn._cache = _pinned_cache(module.kernel)
    return fn


class JitBackend:
    """numba's JIT, its machine code cached in the entry (see the module's doc for the protocol)."""

    name = "jit"

    def load(self, entry, code, warm):
        fn = dispatcher(code.module(entry.kernel_file), cached=True)
        warm(fn)
        if fn.stats.cache_misses:      # numba compiled after all (and wrote its files): list them
            try:
                entry.refresh()
            except OSError:
                pass
        return fn

    def build(self, folder, code, warm):
        fn = dispatcher(code.module(os.path.join(folder, KERNEL_FILE)), cached=True)
        warm(fn)
        fn._cache.disable()      # its files move with the entry's rename; nothing more is written
        return fn

    def memory(self, code, warm=None, filename=None, reuse=False):
        """Compiled in memory, cached nowhere: without a usable cache folder, or for arguments a
        kernel built ahead of time does not take (its module, `reuse`d when made already)."""
        fn = dispatcher(code.module(filename or f"<hapticgraph kernel {code.key}>", reuse), cached=False)
        if warm is not None:
            warm(fn)
        return fn

    def entry_point(self, fn, args):
        try:
            return fn.overloads[tuple(fn.typeof_pyval(a) for a in args)].entry_point
        except (KeyError, AttributeError, TypeError, ValueError):
            return None
