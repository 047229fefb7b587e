"""What the compiled kernels (compiled.py, skimage_values.py) share: numba's njit with its disk cache, the
lock threads take around parallel launches where the threading layer needs one, bit operations as LLVM
intrinsics, and the cells of a word of sign bits (compiled.py's words: 32 samples along axis 2)."""
from __future__ import annotations

import contextlib
import os
import threading

import numba
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from ..core.layout import WORD_BITS

# numba's "omp" threading layer (libgomp, read when its first parallel kernel launches): threads that wait
# for the next launch sleep instead of spinning.  Iso changes come in bursts with idle gaps; a spinning thread
# takes a core from the rest of the process (the viewer's drawing on llvmpipe) and from other programs, and
# on a busy machine is then scheduled late for the next launch, which waits for it (MNI T1 iso change, two
# threads, load ~2.5: 24-36 ms spinning against 7-16 ms).  A value the user set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

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


@_cached_njit(inline="always", error_model="numpy")
def _shifted(signs, i, j, w, nw):
    """The word's bits moved down by one, the next word's first bit on top: bit k is sample k + 1."""
    s = np.int64(signs[i, j, w])
    nxt = (np.int64(signs[i, j, w + 1]) & 1) << (WORD_BITS - 1) if w + 1 < nw else 0
    return (s >> 1) | nxt


@_cached_njit(inline="always", error_model="numpy")
def _cut_cells(signs, i, j, w, nw, cell_mask):
    """The word's cells with corners on both sides of the level (bit k: cell (i, j, 32 w + k)) and its
    four rows' words, plain and shifted by one sample."""
    a = np.int64(signs[i, j, w])
    b = np.int64(signs[i + 1, j, w])
    c = np.int64(signs[i, j + 1, w])
    d = np.int64(signs[i + 1, j + 1, w])
    a1 = _shifted(signs, i, j, w, nw)
    b1 = _shifted(signs, i + 1, j, w, nw)
    c1 = _shifted(signs, i, j + 1, w, nw)
    d1 = _shifted(signs, i + 1, j + 1, w, nw)
    every = a & b & c & d & a1 & b1 & c1 & d1
    some = a | b | c | d | a1 | b1 | c1 | d1
    return (some & ~every) & cell_mask, a, b, c, d, a1, b1, c1, d1


@_cached_njit(inline="always", error_model="numpy")
def _case(k, a, b, c, d, a1, b1, c1, d1):
    return (((a >> k) & 1) | ((b >> k) & 1) << 1 | ((c >> k) & 1) << 2 | ((d >> k) & 1) << 3
            | ((a1 >> k) & 1) << 4 | ((b1 >> k) & 1) << 5 | ((c1 >> k) & 1) << 6 | ((d1 >> k) & 1) << 7)
