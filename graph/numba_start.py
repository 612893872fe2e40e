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

It also lets LLVM use the machine's widest vectors. On a CPU with AVX-512, LLVM's tuning for the
model ("prefer-256-bit") keeps loops at 4 doubles a vector where gcc -march=native uses 8; the
lattices' stencils run 1.3-1.7x faster at 8 (benchmarks/README.md, issue 25). Vectorising an
element-wise loop changes no result, so the kernel still equals the interpreter bit for bit.
`WIDE_VECTORS` is the target feature that says so: the JIT target gets it with the host's
features, the ahead-of-time compile (aot.py) with its CPU model; a user's NUMBA_CPU_NAME or
NUMBA_CPU_FEATURES are left as they are. The kernel cache key names it (cachekey.py).
"""
import importlib.machinery
import importlib.util
import pathlib
import sys

_started = []

WIDE_VECTORS = "-prefer-256-bit"


def wide_features(features):
    """A target's features with WIDE_VECTORS added where it means something (AVX-512 present:
    elsewhere LLVM would warn about a feature it does not know)."""
    flags = features.split(",") if features else []
    if "+avx512f" not in flags:
        return features
    return ",".join([f for f in flags if f.lstrip("+-") != WIDE_VECTORS[1:]] + [WIDE_VECTORS])


def _widen_jit():
    from numba.core import config
    if config.CPU_FEATURES is None and config.CPU_NAME is None:
        import llvmlite.binding as llvm
        config.CPU_FEATURES = wide_features(llvm.get_host_cpu_features().flatten())


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
        if not _started:
            _widen_jit()
        _started.append(True)
        return
    _widen_jit()
    from numba.np import linalg
    real = linalg.ensure_blas
    linalg.ensure_blas = _probe
    try:
        from numba.np import arraymath
        arraymath.ensure_blas = real
    finally:
        linalg.ensure_blas = real
    _started.append(True)
