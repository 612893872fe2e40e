"""numba's start-up, without the scipy import nothing here uses.

When numba's CPU target is first used (a kernel compiled, or loaded from the cache), it imports
`numba.np.arraymath`, whose module-level `_check_blas()` asks `numba.np.linalg.ensure_blas()`
whether `np.dot` and friends can be compiled, by importing `scipy.linalg.cython_blas`. That
import costs 0.2–0.45 s a process (scipy.linalg pulls in scipy's array-API layer, which clones
numpy), about a third of a warm `hapticgraph run`, and no kernel of ours calls BLAS.

`start()` answers that one question from the disk instead: the same answer (is scipy's
cython_blas extension installed?) without importing it. numba's own `ensure_blas` is back in
place before `start()` returns, so a plugin block that does call `np.dot` still gets numba's
real check (and scipy) when its kernel is compiled.
"""
import importlib.machinery
import importlib.util
import pathlib
import sys

_started = []


def _cython_blas_on_disk():
    spec = importlib.util.find_spec("scipy")            # finds the package, imports nothing
    if spec is None or not spec.submodule_search_locations:
        return False
    suffixes = importlib.machinery.EXTENSION_SUFFIXES
    return any((pathlib.Path(where, "linalg", "cython_blas" + suffix)).is_file()
               for where in spec.submodule_search_locations for suffix in suffixes)


def _probe():
    if not _cython_blas_on_disk():
        raise ImportError("scipy.linalg.cython_blas is not installed")


def start():
    """Import numba's array math (its BLAS probe answered from disk); idempotent, cheap after."""
    if _started or "numba.np.arraymath" in sys.modules:
        _started.append(True)
        return
    from numba.np import linalg
    real = linalg.ensure_blas
    linalg.ensure_blas = _probe
    try:
        from numba.np import arraymath
        arraymath.ensure_blas = real
    finally:
        linalg.ensure_blas = real
    _started.append(True)
