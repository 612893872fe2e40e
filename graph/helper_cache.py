"""The machine code of hapticgraph's own @helper functions (the stencils, the network steps, the
guard, ...), compiled by numba once per installation and kept in the shared folder, so that a
cold compile of a kernel compiles the kernel, not every helper it calls again (a 32 x 32 sheet:
3.7 -> 1.6 s).

The entry `numba_helpers_<key>/` of the shared folder (graph/kcache.py's shared_dir) holds numba's
own cache files of those helpers. Its key is the host (graph/cachekey.py: versions, CPU), the
folders of hapticgraph's packages (one entry per installation) and the SHA-256 of every module
file in them, so an edited helper, or one it calls in another file, is compiled afresh in a new
entry. It is verified, never trusted, as a kernel's
entry is: before numba reads anything of it in a process, every file must match the entry's
manifest (none missing, none extra, no link), else the entry is deleted and started empty; what
numba wrote is listed in the manifest after each compile (`settle`) and at exit.

Only the helpers defined in hapticgraph's own packages are cached (a plugin's are compiled with
each kernel, as before); numba finds the folder through a cache locator of ours, first in numba's
list, that claims those functions alone. Without a usable folder, or when NUMBA_CACHE_LOCATOR_CLASSES
replaces numba's list, nothing is cached: helpers compile with each kernel, as before.
"""
import atexit
import hashlib
import importlib.util
import json
import os
import threading

from ..blocks.vocabulary import pending_helpers, register_helpers
from .cachekey import file_digest, host_id
from .kcache import MANIFEST, CacheEntry, listing, usable_cache_dir, usable_shared_dir, write_manifest

PREFIX = "numba_helpers"
PACKAGES = ("blocks", "graph", "devices")      # hapticgraph's packages that define helpers
_claimed = {}           # helper function -> the folder numba caches it in
_store = []             # (CacheEntry, package folders) opened in this process, or None: at most one
_lock = threading.Lock()


def _package_dirs():
    """The folders of hapticgraph's packages (found, not imported)."""
    top = __name__.split(".")[0]
    dirs = []
    for name in PACKAGES:
        spec = importlib.util.find_spec(f"{top}.{name}")
        dirs += [os.path.realpath(d) for d in (spec.submodule_search_locations or ())] if spec else []
    return dirs


def _key(dirs):
    """The host, the packages' folders (an entry per installation: numba's index of a helper
    names its source file's time stamp) and the digest of every module file in them."""
    files = []
    for root in dirs:
        for top, folders, names in os.walk(root):
            folders[:] = [d for d in folders if d != "__pycache__"]
            files += [(os.path.relpath(os.path.join(top, n), root), os.path.join(top, n)) for n in names
                      if n.endswith(".py")]
    h = hashlib.sha256()
    h.update(f"{PREFIX} 1\0{host_id()}\0{os.pathsep.join(dirs)}\0".encode("utf-8", "surrogatepass"))
    for rel, path in sorted(files):
        h.update(f"{rel}\0{file_digest(path)}\0".encode("utf-8", "surrogatepass"))
    return h.hexdigest()[:24]


def _open():
    """(the verified entry of this installation's helpers, the package folders), opened once a
    process; None when nothing can be cached."""
    with _lock:
        if not _store:
            _store.append(_verified())
    return _store[0]


def _verified():
    from numba.core import caching
    root = usable_shared_dir(usable_cache_dir())
    if root is None or os.environ.get("NUMBA_CACHE_LOCATOR_CLASSES"):     # numba's list replaced
        return None
    dirs = _package_dirs()
    try:
        entry = CacheEntry(root, _key(dirs), prefix=PREFIX)
        if not entry.verify():
            entry.remove()
            with entry.fresh() as folder:
                entry.commit(folder)
    except OSError:
        return None
    caching.CompileResultCacheImpl._locator_classes.insert(0, _locator(caching))
    atexit.register(settle)
    return entry, dirs


def _locator(caching):
    class Locator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
        """numba's cache of a claimed helper: in its entry, one folder per module."""

        def __init__(self, py_func, py_file):
            self._py_file, self._lineno = py_file, py_func.__code__.co_firstlineno
            self._path = _claimed[py_func]

        def get_cache_path(self):
            return self._path

        @classmethod
        def from_function(cls, py_func, py_file):
            return cls(py_func, py_file) if py_func in _claimed else None
    return Locator


def _claim(store, fn):
    """True (numba caches fn in the entry) if fn is defined in hapticgraph's packages."""
    entry, dirs = store
    try:
        path = os.path.realpath(fn.__code__.co_filename)
    except (AttributeError, TypeError):
        return False
    if not any(path.startswith(d + os.sep) for d in dirs):
        return False
    _claimed[fn] = os.path.join(entry.path, fn.__module__)
    return True


def register():
    """Register the @helper functions defined since the last call with numba, those of
    hapticgraph's packages cached in this installation's entry; the compiler calls this before
    it jits anything."""
    if not pending_helpers():
        return
    store = _open()
    register_helpers(cached=(lambda fn: _claim(store, fn)) if store is not None else None)


def settle():
    """List in the entry's manifest what numba wrote there since it was verified (after a
    compile, and at exit)."""
    if not _store or _store[0] is None:
        return
    entry = _store[0][0]
    try:
        with open(os.path.join(entry.path, MANIFEST), "rb") as f:
            listed = json.loads(f.read(1 << 22)).get("files", {})
        if listing(entry.path) != sorted([*listed, MANIFEST]):
            write_manifest(entry.path, entry.key)
    except (OSError, ValueError, AttributeError):
        pass


__all__ = ["register", "settle"]
