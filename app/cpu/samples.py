"""A volume's samples as the compiled kernels read them: in place, in any memory order and byte order.

Users' arrays come in many layouts: nibabel returns NIfTI data in Fortran order (axis 0 fastest), a slice
``a[::-1]`` or ``a[:, ::2]`` has negative or wide strides, ANALYZE and some NIfTI files are big-endian,
and scans are 8- or 16-bit integers.  A C-ordered float32 copy of a 512x512x400 int16 CT costs 2.8 s
(the transpose) and 400 MB; the kernels read the samples where they are instead.

`SampleView` holds a 1-D read-only view over the array's memory (`flat`, in the native type of the
samples), the element offset of sample (0, 0, 0) and the element stride of each axis (`at`), whether each
sample's bytes must be swapped (`swap`), and the shape.  Sample (i, j, k) is
``flat[at[0] + i * at[1] + j * at[2] + k * at[3]]``, converted to float32 as ``astype(np.float32)``
converts it (`sample`), so every kernel computes what it computed on the float32 copy, bit for bit.
One compiled version of a kernel serves every layout of a sample type (KERNEL_DTYPES); numba compiles
one per type on first use and caches it on disk.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from llvmlite import ir
from numba.extending import intrinsic

from ..core.layout import IN_PLACE_DTYPES
from .jit import _cached_njit

__all__ = ["KERNEL_DTYPES", "ORDER_C", "ORDER_F", "ORDER_STRIDED", "SampleView", "raw", "sample", "sample_view"]

KERNEL_DTYPES = IN_PLACE_DTYPES

ORDER_C, ORDER_F, ORDER_STRIDED = 0, 1, 2
"""`SampleView.order`: axis 2 is contiguous (C), axis 0 is (Fortran: nibabel's), or neither."""


class SampleView(NamedTuple):
    """A volume's samples as the compiled kernels read them, where they lie: a flat view, whether to swap bytes, the
    grid's offset, strides and shape, and the order to loop in."""
    flat: np.ndarray   # 1-D, read-only, the samples' type in native byte order (the bytes as stored)
    swap: bool         # the stored bytes are in the other byte order: swap them on every read
    grid: np.ndarray   # int64 (offset, stride 0, stride 1, stride 2, n0, n1, n2): strides in elements
    order: int         # ORDER_C, ORDER_F or ORDER_STRIDED: which loops read it in memory order

    @property
    def shape(self) -> tuple[int, int, int]:
        """The volume's (n0, n1, n2)."""
        return tuple(int(n) for n in self.grid[4:])


def sample_view(array: np.ndarray) -> SampleView:
    """`array` (3-D numeric) as the kernels read it: in place where its type is one of KERNEL_DTYPES and its
    strides are whole elements, else a C-ordered float32 copy (what the kernels computed on before)."""
    array = np.asarray(array)
    native = array.dtype.newbyteorder("=")
    itemsize = array.dtype.itemsize
    if str(native) not in KERNEL_DTYPES or any(s % itemsize for s in array.strides) or array.size == 0:
        array = np.ascontiguousarray(array, dtype=np.float32)
        native, itemsize = array.dtype, 4
    steps = [s // itemsize for s in array.strides]
    # The lowest address the array reaches: its start moved back along every axis it walks backwards.
    lowest = array[tuple(slice(None, None, -1) if s < 0 else slice(None) for s in steps)]
    span = 1 + sum((n - 1) * abs(s) for n, s in zip(array.shape, steps))
    flat = np.lib.stride_tricks.as_strided(lowest.view(native) if lowest.dtype != native else lowest,
                                           shape=(span,), strides=(itemsize,), writeable=False)
    offset = sum((n - 1) * -s for n, s in zip(array.shape, steps) if s < 0)
    n0, n1, n2 = (int(n) for n in array.shape)
    if steps[2] == 1 or n2 == 1:
        order = ORDER_C
    elif steps[0] == 1 or n0 == 1:
        order = ORDER_F
    else:
        order = ORDER_STRIDED
    swap = not array.dtype.isnative and itemsize > 1
    return SampleView(flat, swap, np.array([offset, *steps, n0, n1, n2], np.int64), order)


@intrinsic
def _bswap(typingctx, x):
    """x with its bytes in reverse order (LLVM's bswap on the bits of an integer or a float)."""
    def codegen(context, builder, signature, args):
        value = args[0]
        kind = value.type
        if isinstance(kind, ir.IntType):
            return builder.bswap(value) if kind.width > 8 else value
        bits = ir.IntType(64 if isinstance(kind, ir.DoubleType) else 32)
        return builder.bitcast(builder.bswap(builder.bitcast(value, bits)), kind)
    return x(x), codegen


@_cached_njit(inline="always", error_model="numpy")
def raw(flat, swap, index):
    """The stored sample at flat index `index`, in its own type (bytes swapped where stored the other way).  The
    index goes in unsigned (it is never negative): numba then adds no wraparound test to each read."""
    value = flat[np.uint64(index)]
    if swap:
        value = _bswap(value)
    return value


@_cached_njit(inline="always", error_model="numpy")
def sample(flat, swap, grid, i, j, k):
    """Sample (i, j, k) as float32 (what astype(np.float32) makes of it).  The kernels take a view's fields
    one by one (numba's parallel loops capture arrays and scalars, not tuples)."""
    return np.float32(raw(flat, swap, grid[0] + i * grid[1] + j * grid[2] + k * grid[3]))
