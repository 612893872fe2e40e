"""The kernel cache: the key that names a kernel (everything its machine code depends on) and the
verified cache folder (see graph/kernel.py for the rules). A cache entry is used only when it is
exactly what a compile of the same source wrote; anything else is rebuilt, never run."""
import hashlib
import inspect
import json
import os
import platform
import shutil
import sys
import tempfile
import types

from . import aot

_warned = []            # the one "cache not usable" warning, given at most once per process
MANIFEST = "manifest.json"


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


# -- the cache key: everything the machine code depends on --------------------------------------

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


def _version(dist):
    from importlib import metadata
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "?"


def _host_id():
    """Versions and the CPU the machine code is made for, told without importing numba (a warm
    start loads an extension module and never imports it: graph/aot.py)."""
    if not _host:
        import numpy
        _host.append("\0".join([_version("numba"), _version("llvmlite"), numpy.__version__, sys.version,
                                sys.implementation.cache_tag or "", platform.machine(), _cpu(),
                                os.environ.get("NUMBA_CPU_NAME", ""), os.environ.get("NUMBA_CPU_FEATURES", "")]))
    return _host[0]


def _codes(code):
    yield code
    for c in code.co_consts:
        if inspect.iscode(c):
            yield from _codes(c)


def _reachable_files(fns):
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
        top = (fn.__module__ or "").split(".")[0]
        if top in _SKIP_TOP:
            continue
        path = getattr(sys.modules.get(fn.__module__), "__file__", None)
        if path:
            files.add(os.path.realpath(path))
        else:
            anonymous.append(fn.__code__.co_code)
        g = fn.__globals__
        for code in _codes(fn.__code__):
            for name in code.co_names:
                value = g.get(name)
                if inspect.ismodule(value):
                    if value.__name__.split(".")[0] in _SKIP_TOP:
                        continue
                    todo += [getattr(value, attr, None) for attr in code.co_names]
                elif value is not None:
                    todo.append(value)
    return files, anonymous


def _file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def kernel_key(source, fns, prog):
    """The hash that names a kernel's cache entry."""
    h = hashlib.sha256()

    def add(text):
        h.update(str(text).encode("utf-8", "surrogatepass"))
        h.update(b"\0")
    add("hapticgraph kernel 3")
    add(source)
    add(_host_id())
    from .kernel import jit
    files, anonymous = _reachable_files(list(fns) + [jit])
    registry = getattr(prog.patch, "registry", None)
    files |= {os.path.realpath(p) for p in getattr(registry, "plugin_files", ())}
    for path in sorted(files):
        add(path)
        try:
            add(_file_digest(path))
        except OSError as exc:
            add(f"unreadable: {exc}")
    for code in anonymous:
        add(hashlib.sha256(code).hexdigest())
    return h.hexdigest()[:24]


# -- the cache folder -------------------------------------------------------------------------

def _say(text):
    from . import kernel
    if kernel.notice is not None:
        kernel.notice(text)


def _warn_once(text):
    if not _warned:
        _warned.append(text)
        print(f"hapticgraph: warning: {text}", file=sys.stderr, flush=True)


def usable_cache_dir():
    """The cache folder if it can hold kernels (a folder we own, writable, not world-writable);
    else None after one warning: kernels are then compiled in memory."""
    root = cache_dir()
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.stat(root)
        if not os.path.isdir(root):
            raise NotADirectoryError("not a folder")
        if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
            raise PermissionError("owned by another user")
        if hasattr(os, "geteuid") and st.st_mode & 0o002:
            raise PermissionError("writable by every user")
        tempfile.TemporaryFile(dir=root).close()
    except OSError as exc:
        reason = exc.strerror or str(exc) or type(exc).__name__
        _warn_once(f"kernel cache {root!r} is not usable ({reason}); compiling in memory "
                   "(set HAPTICGRAPH_CACHE to a folder of yours)")
        return None
    return root


def _listing(folder):
    """Every file under folder (relative paths with /), or None if a link or odd file is there."""
    found = []
    for top, dirs, names in os.walk(folder, followlinks=False):
        for d in dirs:
            if os.path.islink(os.path.join(top, d)):
                return None
        for n in names:
            path = os.path.join(top, n)
            if os.path.islink(path) or not os.path.isfile(path):
                return None
            found.append(os.path.relpath(path, folder).replace(os.sep, "/"))
    return sorted(found)


def verified_files(folder, key):
    """True if folder holds exactly what its manifest lists (the key given, every file with its
    hash, none missing, none extra, no link)."""
    try:
        if os.path.islink(folder) or not os.path.isdir(folder):
            return False
        with open(os.path.join(folder, MANIFEST), "rb") as f:
            manifest = json.loads(f.read(1 << 20))
        files = manifest.get("files") if isinstance(manifest, dict) else None
        if manifest.get("key") != key or not isinstance(files, dict):
            return False
        listing = _listing(folder)
        if listing is None or sorted(list(files) + [MANIFEST]) != listing:
            return False
        return all(isinstance(d, str) and _file_digest(os.path.join(folder, *rel.split("/"))) == d
                   for rel, d in files.items())
    except (OSError, ValueError, AttributeError, TypeError):
        return False


def verified(entry, source, key):
    """True if the entry folder is exactly what a compile of this source wrote: kernel.py is the
    source, and every file is listed in the manifest with its hash (none missing, none extra)."""
    try:
        if os.path.islink(entry):
            return False
        with open(os.path.join(entry, "kernel.py"), "rb") as f:
            if f.read() != source.encode("utf-8"):
                return False
    except OSError:
        return False
    return verified_files(entry, key)


def _write_manifest(entry, key):
    files = {rel: _file_digest(os.path.join(entry, *rel.split("/")))
             for rel in (_listing(entry) or ()) if rel != MANIFEST}
    tmp = os.path.join(entry, MANIFEST + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump({"key": key, "files": files}, f, indent=1, sort_keys=True)
    os.replace(tmp, os.path.join(entry, MANIFEST))


def _remove(path):
    if os.path.islink(path) or os.path.isfile(path):
        os.remove(path)
    elif os.path.isdir(path):
        shutil.rmtree(path)


_cache_class = []


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


def _module(name, source, filename):
    """The kernel module, executed from the source in memory (no .pyc is written or read)."""
    module = types.ModuleType(name)
    module.__file__ = filename
    sys.modules[name] = module   # numba re-imports it by name when it loads cached code
    try:
        exec(compile(source, filename, "exec"), module.__dict__)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _dispatcher(module, cached):
    import numba
    from ..blocks.vocabulary import register_helpers
    from .numba_start import start
    start()
    register_helpers()      # the @helper functions defined since the last compile
    fn = numba.njit(nogil=True)(module.kernel)
    if cached:
        fn._cache = _pinned_cache(module.kernel)
    return fn


def _arguments(warm):
    """The arguments `warm` calls the kernel with (those it is compiled for)."""
    got = []
    warm(lambda *args: got.append(args))
    return got[0]


def _jit(name, source, filename):
    """Makes the numba dispatcher, compiled in memory: a native kernel's fallback for arguments
    its extension module was not built for."""
    def make():
        _say("compiling the kernel with numba for arguments of other types…")
        return _dispatcher(sys.modules.get(name) or _module(name, source, filename), cached=False)
    return make


def _from_entry(entry, name, source, key, warm):
    """(kernel, path of kernel.py) from a verified entry: its extension module (numba is not
    imported), else numba's cache."""
    path = os.path.join(entry, "kernel.py")
    fn = aot.load(entry, _jit(name, source, path)) if aot.enabled() else None
    if fn is not None:
        warm(fn)
        return fn, path
    fn = _dispatcher(_module(name, source, path), cached=True)
    warm(fn)
    if fn.stats.cache_misses:      # numba compiled after all (and wrote its files): list them
        try:
            _write_manifest(entry, key)
        except OSError:
            pass
    return fn, path


def _into_entry(root, entry, name, source, key, warm):
    """(kernel, path of kernel.py): compiled into a fresh folder (an extension module, else
    numba's cache), which then becomes the entry."""
    tmp = None
    try:
        tmp = tempfile.mkdtemp(prefix=f".kernel_{key}.", dir=root)
        with open(os.path.join(tmp, "kernel.py"), "w", encoding="utf-8") as f:
            f.write(source)
        module = _module(name, source, os.path.join(tmp, "kernel.py"))
        fn = aot.native(tmp, module.kernel, _arguments(warm), root, _say,
                        _jit(name, source, os.path.join(entry, "kernel.py")))
        if fn is None:
            fn = _dispatcher(module, cached=True)
            warm(fn)
            fn._cache.disable()      # its files move with the rename below; nothing more is written
        else:
            warm(fn)
        _write_manifest(tmp, key)
        try:
            os.rename(tmp, entry)
        except OSError:
            if verified(entry, source, key):    # another process finished the same kernel first
                _remove(tmp)
            else:
                _remove(entry)
                os.rename(tmp, entry)
        return fn, os.path.join(entry, "kernel.py")
    except BaseException:   # numba cannot compile it, or an interrupt: leave nothing behind
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        sys.modules.pop(name, None)
        raise


def _compile(key, source, label, warm):
    """(kernel, path of kernel.py or None): from a verified cache entry, else compiled (into a
    fresh entry when the cache folder is usable, else in memory)."""
    name = f"hapticgraph_kernel_{key}"
    root = usable_cache_dir()
    if root is not None:
        entry = os.path.join(root, f"kernel_{key}")
        if verified(entry, source, key):
            return _from_entry(entry, name, source, key, warm)
        _say(f"compiling {label}…")
        try:
            return _into_entry(root, entry, name, source, key, warm)
        except OSError as exc:
            _warn_once(f"kernel cache {root!r}: {exc.strerror or exc}; compiling in memory")
    else:
        _say(f"compiling {label}…")
    fn = _dispatcher(_module(name, source, f"<hapticgraph kernel {key}>"), cached=False)
    warm(fn)
    return fn, None
