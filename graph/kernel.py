"""The compiler's orchestration: generate ONE readable kernel module per program (graph/codegen.py),
name it by its key (graph/cachekey.py), find it in the verified cache (graph/kcache.py) or have a
backend build it there (ahead of time, graph/aot.py, else numba's JIT, graph/jit.py), and run it.

The cache is verified, never trusted (graph/kcache.py): an entry is used only when its kernel.py
is byte for byte the source just generated and every file matches its manifest.
"""
import os
import sys
import time

import numpy as np

from . import aot
from .aot import AotBackend
from .cachekey import kernel_key
from .codegen import generate, support_files
from .helper_cache import settle as settle_helpers
from .identifiers import note
from .jit import JitBackend, KernelCode, jit
from .kcache import CacheEntry, cache_dir, usable_cache_dir, warn_once

__all__ = ["CompiledKernel", "compile_kernel", "generate", "set_notice"]

_notice = []            # who is told that a kernel is compiled (set_notice); nobody by default
_loaded = {}            # (cache folder, key) -> (kernel, path, backend): kernels this process compiled or loaded
JIT = JitBackend()


def set_notice(tell):
    """`tell(text)` (one line) is told when a kernel is compiled rather than loaded from the cache
    (the command line prints it unless --quiet); None: nobody. Library code prints nothing by default."""
    _notice[:] = [tell] if tell is not None else []


def _say(text):
    for tell in _notice:
        tell(text)


def backends(root):
    """The backends that build and load kernels in the cache folder `root`, in order of preference."""
    return ([AotBackend(root, _say, JIT)] if aot.enabled() else []) + [JIT]


def compile_kernel(key, source, label, warm):
    """(kernel, path of kernel.py or None, backend, compiled): from a verified cache entry
    (compiled False), else compiled (into a fresh entry when the cache folder is usable, else in
    memory)."""
    code = KernelCode(key, source)
    root = usable_cache_dir()
    if root is not None:
        entry = CacheEntry(root, key)
        if entry.verify(source):
            for backend in backends(root):
                fn = backend.load(entry, code, warm)
                if fn is not None:
                    return fn, entry.kernel_file, backend, False
        _say(f"compiling {label}…")
        try:
            return (*_into_entry(entry, code, warm), True)
        except OSError as exc:
            warn_once(f"kernel cache {root!r}: {exc.strerror or exc}; compiling in memory")
    else:
        _say(f"compiling {label}…")
    try:
        return JIT.memory(code, warm), None, JIT, True
    finally:
        settle_helpers()


def _into_entry(entry, code, warm):
    """(kernel, path of kernel.py, backend): built by the first backend that can into a fresh
    folder, which then becomes the entry."""
    try:
        with entry.fresh() as folder:
            with open(os.path.join(folder, "kernel.py"), "w", encoding="utf-8") as f:
                f.write(code.source)
            for backend in backends(entry.root):
                fn = backend.build(folder, code, warm)
                if fn is not None:
                    break
            entry.commit(folder, code.source)
    except BaseException:   # numba cannot compile it, or an interrupt: nothing left behind
        code.forget()
        raise
    finally:
        settle_helpers()    # what numba cached of the helpers, listed
    return fn, entry.kernel_file, backend


class CompiledKernel:
    """The imported, jitted kernel of a program; `run(t0, rec)` fills rec (n × records)."""

    def __init__(self, prog, label=None):
        start = time.perf_counter()     # numba is started where it is used: a native kernel needs none
        self.prog = prog
        source, fns = generate(prog)
        self.source = source
        self.key = kernel_key(source, list(fns) + [jit], [*prog.patch.registry.plugin_files, *support_files()])
        self.extra = tuple(prog.buffers) + tuple(prog.arrays)

        def warm(fn):
            # compile now (or load numba's cache), so the first block of audio is not late
            fn(0, 0, prog.state, prog.live, prog.coef, np.zeros((0, len(prog.records))),
               np.zeros((0, len(prog.ext_columns))), *self.extra)
        label = label or f"kernel for {len(prog.plans)} block{'s' if len(prog.plans) != 1 else ''}"
        where = (cache_dir(), self.key)
        loaded = _loaded.get(where)
        if loaded is None:          # `compiled`: made here and now, not loaded from the cache
            *loaded, self.compiled = compile_kernel(self.key, source, label, warm)
            loaded = _loaded[where] = tuple(loaded)
        else:
            self.compiled = False
            warm(loaded[0])
        self.fn, self.path, self.backend = loaded
        if os.environ.get("HAPTICGRAPH_DUMP") == "1":
            where = self.path or "compiled in memory (no usable cache folder)"
            print(f"hapticgraph: kernel for {note(prog.patch.name)} is {where}", file=sys.stderr)
        self.compile_seconds = time.perf_counter() - start

    def run(self, t0, rec, ext):
        """Run rec.shape[0] samples from t0; the guard's code (0: sound; graph/guard.py).

        The same rec and ext as the last call (a Session's views) go straight to the machine code
        compiled for their types (the backend's entry point), skipping the dispatcher's typing of
        every argument (about 0.5 µs a call; for a kernel built ahead of time, its module's
        function without the per-call type checks, done once when remembered); anything else goes
        through the dispatcher, which types it, and is remembered, when it comes twice in a row,
        if its types are the ones compiled (the Program's arrays are never rebound, so they are
        remembered with it)."""
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
        """Keep the entry point compiled for exactly these arguments' types."""
        if type(t0) is not int:     # Session's counter; numba types other numbers otherwise
            return
        p = self.prog
        entry = self.backend.entry_point(self.fn, (rec.shape[0], t0, p.state, p.live, p.coef, rec, ext) + self.extra)
        if entry is None:
            self._rec = self._ext = None
            return
        self._entry, self._state, self._live, self._coef = entry, p.state, p.live, p.coef
        self._rec, self._ext = rec, ext
