"""The kernel's side of graph/denormals.py: two numba intrinsics the generated kernel calls around
its sample loop, `flush_enter()` (the SSE control register MXCSR as it was, then flush-to-zero
and denormals-are-zero set) and `flush_exit(saved)` (the register put back). They compile to one
`stmxcsr` and one `ldmxcsr` each (LLVM's llvm.x86.sse.* intrinsics), so a kernel called once a
sample (a 20 kHz servo loop) pays a few cycles, not the C library's fegetenv/fesetenv (x87 state
included, about 2 µs a call through ctypes), which the interpreter uses instead: the same bits of
the same register, so both engines round alike.

Imported only by generated kernel modules, and only where denormals.SUPPORTED (x86-64 Linux).
"""
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from .denormals import FLUSH_BITS
from .numba_start import start

start()

__all__ = ["flush_enter", "flush_exit"]

_I32 = ir.IntType(32)
_VOID_OF_POINTER = ir.FunctionType(ir.VoidType(), [ir.IntType(8).as_pointer()])


def _register(builder, name, slot):
    fn = cgutils.get_or_insert_function(builder.module, _VOID_OF_POINTER, name)
    builder.call(fn, [builder.bitcast(slot, ir.IntType(8).as_pointer())])


@intrinsic
def flush_enter(typingctx):
    """MXCSR as it was (uint32); flush-to-zero and denormals-are-zero set from here on."""
    def codegen(context, builder, signature, args):
        slot = cgutils.alloca_once(builder, _I32)
        _register(builder, "llvm.x86.sse.stmxcsr", slot)
        saved = builder.load(slot)
        builder.store(builder.or_(saved, ir.Constant(_I32, FLUSH_BITS)), slot)
        _register(builder, "llvm.x86.sse.ldmxcsr", slot)
        return saved
    return types.uint32(), codegen


@intrinsic
def flush_exit(typingctx, saved):
    """MXCSR put back as flush_enter found it."""
    def codegen(context, builder, signature, args):
        slot = cgutils.alloca_once(builder, _I32)
        builder.store(args[0], slot)
        _register(builder, "llvm.x86.sse.ldmxcsr", slot)
        return context.get_dummy_value()
    return types.void(saved), codegen
