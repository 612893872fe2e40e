"""Subnormal numbers flushed to zero while a kernel runs, in every engine alike.

A damped instrument left ringing decays exponentially: after some tens of seconds (a 100 × 100
sheet, 30 s) its positions fall below 2.2e-308, the smallest normal double, and every operation
on such a subnormal number takes the processor's slow path, about 100 times slower. The kernel's
cost then grows 35-fold at the moment the instrument has gone quiet, and a real-time run
collapses (benchmarks/realtime.py). Audio software turns the processor's flush-to-zero and
denormals-are-zero modes on around its processing (SuperCollider's and JUCE's audio threads,
Faust's `-ftz`); so do we: `FlushToZero` is entered by the reference interpreter's `run`
(graph/interpreter.py) and the compiled and ahead-of-time kernels do the same around their
sample loop (graph/fpenv.py); both put the caller's mode back when the run returns, so nothing
outside a kernel (numpy, scipy, the caller's own arithmetic) sees the change.

The mode is the processor's, so the interpreter's Python floats and the kernel's machine code
round alike and the engines still agree bit for bit. A result differs from strict IEEE only
where a number would have been below 2.2e-308 (zero instead): far below anything physical.

Where it is set: the SSE control register (MXCSR: FTZ, bit 15, and DAZ, bit 6) on x86-64 Linux.
The interpreter goes through the C library's fegetenv/fesetenv (MXCSR's place in glibc's fenv_t:
offset 28); the compiled kernel sets the register itself around its sample loop (graph/fpenv.py:
one instruction each way, not 2 µs of ctypes a call). Elsewhere `SUPPORTED` is False, neither
engine flushes, and runs are plain IEEE (slower as they decay, not different between engines).
"""
import ctypes
import ctypes.util
import platform
import sys

__all__ = ["FLUSH_BITS", "FlushToZero", "SUPPORTED"]

FLUSH_BITS = (1 << 15) | (1 << 6)         # MXCSR: flush-to-zero (FTZ), denormals-are-zero (DAZ)
_WORD = 7                                 # MXCSR's place in glibc's x86-64 fenv_t (offset 28)
_FE_DFL_ENV = ctypes.c_void_p(-1)         # glibc's FE_DFL_ENV: ((const fenv_t *) -1)


class _Env(ctypes.Structure):
    _fields_ = [("words", ctypes.c_uint32 * 16)]     # larger than any fenv_t it stands for


def _libm():
    if not sys.platform.startswith("linux") or platform.machine() != "x86_64":
        return None
    name = ctypes.util.find_library("m")
    if name is None:
        return None
    lib = ctypes.CDLL(name)
    for fn in (lib.fegetenv, lib.fesetenv):
        fn.argtypes, fn.restype = [ctypes.c_void_p], ctypes.c_int
    return lib


_LIBM = _libm()
SUPPORTED = _LIBM is not None


def _flushing_env():
    """The default environment (round to nearest, no flag raised) with the flush bits set."""
    saved, env = _Env(), _Env()
    _LIBM.fegetenv(ctypes.byref(saved))
    _LIBM.fesetenv(_FE_DFL_ENV)
    _LIBM.fegetenv(ctypes.byref(env))
    _LIBM.fesetenv(ctypes.byref(saved))
    env.words[_WORD] |= FLUSH_BITS
    return env


_FLUSHING = ctypes.byref(_flushing_env()) if SUPPORTED else None


class FlushToZero:
    """`with flush:` runs its body with subnormals flushed to zero (inputs and results), then puts
    the thread's floating-point environment back as it was. One per engine object: it keeps the
    environment it replaced, so one thread at a time enters it (a Session runs in one)."""

    __slots__ = ("_saved", "_ref")

    def __init__(self):
        self._saved = _Env()
        self._ref = ctypes.byref(self._saved)

    def __enter__(self):
        if SUPPORTED:
            _LIBM.fegetenv(self._ref)
            _LIBM.fesetenv(_FLUSHING)
        return self

    def __exit__(self, kind, value, tb):
        if SUPPORTED:
            _LIBM.fesetenv(self._ref)
        return False
