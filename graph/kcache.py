"""The kernel cache: a folder of entries, each verified, never trusted.

Each kernel has its own entry folder `kernel_<key>/` (graph/cachekey.py makes the key) holding
`kernel.py`, what a backend built beside it (numba's `__pycache__/`, or an extension module and
`aot.json`: graph/jit.py, graph/aot.py) and `manifest.json` (the SHA-256 of every other file),
written after a successful compile. An entry is used only when `kernel.py` is byte for byte the
source just generated and every file matches the manifest (no file missing, none extra, no link);
otherwise it is deleted and rebuilt. An entry is filled in a fresh hidden folder and renamed into
place when complete, so a half-written one is never seen. The cache folder itself must be ours,
writable and not world-writable; else kernels are compiled in memory (one warning). What every
kernel needs (numba's C runtime: graph/aot.py; the built-in helpers' machine code:
graph/helper_cache.py) is built once per installation in the shared folder (shared_dir), checked
the same way, with entries of the same kind.
"""
import contextlib
import json
import os
import shutil
import sys
import tempfile

from .cachekey import file_digest

MANIFEST = "manifest.json"
KERNEL_FILE = "kernel.py"
_warned = []            # the one "cache not usable" warning, given at most once per process
_POSIX = os.name == "posix"      # owners and permission bits mean something


def user_cache_dir():
    """The user cache directory of this platform's hapticgraph: the kernel cache folder unless
    HAPTICGRAPH_CACHE names another, and the shared folder unless HAPTICGRAPH_SHARED_CACHE does."""
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.expanduser("~")
    elif sys.platform == "darwin":
        base = os.path.expanduser("~/Library/Caches")
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    return os.path.join(base, "hapticgraph")


def cache_dir():
    """HAPTICGRAPH_CACHE, else the user cache directory of this platform."""
    return os.environ.get("HAPTICGRAPH_CACHE") or user_cache_dir()


def shared_dir():
    """HAPTICGRAPH_SHARED_CACHE, else the user cache directory of this platform: where what every
    kernel of this installation needs from numba (its C runtime, the built-in helpers' machine
    code) is built once, whatever kernel cache folder HAPTICGRAPH_CACHE names."""
    return os.environ.get("HAPTICGRAPH_SHARED_CACHE") or user_cache_dir()


def warn_once(text):
    """A warning about the cache on stderr, the first one of this process only."""
    if not _warned:
        _warned.append(text)
        print(f"hapticgraph: warning: {text}", file=sys.stderr, flush=True)


def refusal(root):
    """None if the folder `root` can hold cache entries (made if missing; ours, writable, not
    world-writable), else why not."""
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.stat(root)
        if not os.path.isdir(root):
            raise NotADirectoryError("not a folder")
        if _POSIX and st.st_uid != os.geteuid():
            raise PermissionError("owned by another user")
        if _POSIX and st.st_mode & 0o002:
            raise PermissionError("writable by every user")
        tempfile.TemporaryFile(dir=root).close()
    except OSError as exc:
        return exc.strerror or str(exc) or type(exc).__name__
    return None


def usable_cache_dir():
    """The cache folder if it can hold kernels (a folder we own, writable, not world-writable);
    else None after one warning: kernels are then compiled in memory."""
    root = cache_dir()
    reason = refusal(root)
    if reason is not None:
        warn_once(f"kernel cache {root!r} is not usable ({reason}); compiling in memory "
                  "(set HAPTICGRAPH_CACHE to a folder of yours)")
        return None
    return root


def usable_shared_dir(fallback):
    """The shared folder (shared_dir) if it can hold cache entries, as the kernel cache folder
    must; else, after one warning, `fallback` (the kernel cache folder, or None: built there
    instead, or not kept)."""
    root = shared_dir()
    if fallback is not None and os.path.realpath(root) == os.path.realpath(fallback):
        return fallback
    reason = refusal(root)
    if reason is not None:
        warn_once(f"shared cache {root!r} is not usable ({reason}); what numba needs for every kernel is built "
                  f"{'in ' + repr(fallback) if fallback else 'with each kernel'} (set HAPTICGRAPH_SHARED_CACHE "
                  "to a folder of yours)")
        return fallback
    return root


def listing(folder):
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
        found = listing(folder)
        if found is None or sorted(list(files) + [MANIFEST]) != found:
            return False
        return all(isinstance(d, str) and file_digest(os.path.join(folder, *rel.split("/"))) == d
                   for rel, d in files.items())
    except (OSError, ValueError, AttributeError, TypeError):
        return False


def write_manifest(folder, key):
    """List every file of folder with its hash (and the key) in its manifest."""
    files = {rel: file_digest(os.path.join(folder, *rel.split("/")))
             for rel in (listing(folder) or ()) if rel != MANIFEST}
    tmp = os.path.join(folder, MANIFEST + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump({"key": key, "files": files}, f, indent=1, sort_keys=True)
    os.replace(tmp, os.path.join(folder, MANIFEST))


def remove(path):
    """A file, link or folder gone."""
    if os.path.islink(path) or os.path.isfile(path):
        os.remove(path)
    elif os.path.isdir(path):
        shutil.rmtree(path)


class CacheEntry:
    """One entry of the cache folder `root`: the folder `<prefix>_<key>` (`path`).

    verify(source)  True if it is exactly what a compile of this source wrote (kernel.py is the
                    source, when given; every file in the manifest with its hash)
    fresh()         a context giving a new hidden folder to fill (removed if the block fails)
    commit(folder)  that folder, listed in its manifest, becomes the entry (another process that
                    finished the same entry first wins; a stale entry is replaced)
    refresh()       list the entry's files again (a backend added some to a verified entry)
    remove()        delete the entry
    """

    def __init__(self, root, key, prefix="kernel"):
        self.root, self.key, self.prefix = root, key, prefix
        self.path = os.path.join(root, f"{prefix}_{key}")
        self.kernel_file = os.path.join(self.path, KERNEL_FILE)

    def verify(self, source=None):
        if source is not None:
            try:
                if os.path.islink(self.path):
                    return False
                with open(self.kernel_file, "rb") as f:
                    if f.read() != source.encode("utf-8"):
                        return False
            except OSError:
                return False
        return verified_files(self.path, self.key)

    @contextlib.contextmanager
    def fresh(self):
        folder = tempfile.mkdtemp(prefix=f".{self.prefix}_{self.key}.", dir=self.root)
        try:
            yield folder
        except BaseException:   # a failed compile or an interrupt: leave nothing behind
            shutil.rmtree(folder, ignore_errors=True)
            raise
        if os.path.isdir(folder):       # not committed
            shutil.rmtree(folder, ignore_errors=True)

    def commit(self, folder, source=None):
        write_manifest(folder, self.key)
        try:
            os.rename(folder, self.path)
        except OSError:
            if self.verify(source):     # another process finished the same entry first
                remove(folder)
            else:
                self.remove()
                os.rename(folder, self.path)

    def refresh(self):
        write_manifest(self.path, self.key)

    def remove(self):
        remove(self.path)
