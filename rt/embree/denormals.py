"""Denormal floats flushed to zero in the threads that trace (x86's MXCSR flush-to-zero and
denormals-are-zero bits), as Embree asks at start-up ("can have a severe performance impact").
On the 2-vCPU AVX-512 Xeon the robust traversal's arithmetic made denormals in a closed room and
every one of them trapped to microcode: its camera rays traced at 3.0 Mrays/s on one thread,
10.5 with the bits set (report/HISTORY.md); the AMD EPYC before it showed no difference.

The tracer's pool threads set the bits once (flush_denormals, their initializer); work run on
the caller's thread sets them for its duration (flushed()). Elsewhere than on x86-64 nothing is
changed."""
from __future__ import annotations

import contextlib
import platform

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from rt.embree.jit import njit

X86 = platform.machine().lower() in ("x86_64", "amd64")
FTZ_DAZ = 0x8040  # MXCSR bit 15 flush-to-zero, bit 6 denormals-are-zero


def _csr_call(builder, name: str, slot) -> None:
    fnty = ir.FunctionType(ir.VoidType(), [ir.IntType(8).as_pointer()])
    fn = cgutils.get_or_insert_function(builder.module, fnty, name)
    builder.call(fn, [builder.bitcast(slot, ir.IntType(8).as_pointer())])


@intrinsic
def _get_csr(typingctx):
    def codegen(context, builder, signature, args):
        slot = cgutils.alloca_once(builder, ir.IntType(32))
        _csr_call(builder, "llvm.x86.sse.stmxcsr", slot)
        return builder.load(slot)

    return types.uint32(), codegen


@intrinsic
def _set_csr(typingctx, value):
    if value != types.uint32:
        return None

    def codegen(context, builder, signature, args):
        slot = cgutils.alloca_once(builder, ir.IntType(32))
        builder.store(args[0], slot)
        _csr_call(builder, "llvm.x86.sse.ldmxcsr", slot)
        return context.get_dummy_value()

    return types.void(types.uint32), codegen


@njit(cache=True)
def _mxcsr():
    return _get_csr()


@njit(cache=True)
def _set_mxcsr(value):
    _set_csr(np.uint32(value))


def mxcsr() -> int | None:
    """This thread's MXCSR, or None off x86-64."""
    return int(_mxcsr()) if X86 else None


def flush_denormals() -> None:
    """Set flush-to-zero and denormals-are-zero in this thread (a pool thread's initializer)."""
    if X86:
        _set_mxcsr(int(_mxcsr()) | FTZ_DAZ)


@contextlib.contextmanager
def flushed():
    """flush_denormals for the duration of a block on the calling thread, its MXCSR restored after."""
    if not X86:
        yield
        return
    old = int(_mxcsr())
    _set_mxcsr(old | FTZ_DAZ)
    try:
        yield
    finally:
        _set_mxcsr(old)
