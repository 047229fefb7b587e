"""What the compiled kernels (compiled.py, skimage_values.py) share: numba's njit with its disk cache, the
lock threads take around parallel launches where the threading layer needs one, and bit operations as
LLVM intrinsics."""
from __future__ import annotations

import contextlib
import threading

import numba
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

_SERIAL = threading.Lock()


def _launch_guard():
    """What a thread holds while it runs the parallel kernels: numba's "workqueue" threading layer (the one
    a plain pip install gets on macOS and Windows) aborts the process when two threads launch parallel
    kernels at once (a viewer's preview and its full-resolution worker), so there they take turns;
    the "omp" and "tbb" layers are thread-safe and need no lock."""
    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel kernel has run yet, so the layer is not chosen: take turns
        return _SERIAL
    return _SERIAL if layer == "workqueue" else contextlib.nullcontext()


def _cached_njit(**options):
    """numba's njit with its output cached on disk (cache=True: __pycache__ beside this file, else the
    user's cache directory), or compiled afresh in each process where no cache directory can be written."""
    def wrap(function):
        try:
            return njit(cache=True, **options)(function)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return njit(**options)(function)
    return wrap


@intrinsic
def _popcount(typingctx, x):
    """The set bits of an int64: LLVM's ctpop (one instruction where the CPU has one)."""
    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])
    return types.int64(types.int64), codegen


@intrinsic
def _lowest_bit(typingctx, x):
    """The index of the lowest set bit of a non-zero int64: LLVM's cttz."""
    def codegen(context, builder, signature, args):
        return builder.cttz(args[0], ir.Constant(ir.IntType(1), 1))
    return types.int64(types.int64), codegen


@intrinsic
def _take(typingctx, counter):
    """counter[0] += 1 as one atomic step (LLVM's atomicrmw add); returns the value before."""
    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        one = ir.Constant(ir.IntType(64), 1)
        return builder.atomic_rmw("add", array.data, one, "monotonic")
    return types.int64(counter), codegen


@_cached_njit(inline="always", error_model="numpy")
def _low_bits(count):
    """A mask of the lowest `count` bits (0 <= count <= 32)."""
    return (np.int64(1) << count) - 1
