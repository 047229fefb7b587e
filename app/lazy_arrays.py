"""Arrays that are not all in memory: memory-mapped files (np.memmap) and Zarr arrays.

Both are read a block at a time (`array[slices]`).  A memory map's pages, once read,
stay in the process's resident set until the map is told to drop them; `release_pages`
does that after each block, so reading a mapped file block by block keeps the resident
memory near one block instead of growing to the whole file.
"""
from __future__ import annotations

import mmap

import numpy as np


def is_lazy(array) -> bool:
    """True for an array-like read on demand (Zarr and the like), not a numpy array."""
    return not isinstance(array, np.ndarray) and all(hasattr(array, a) for a in ("shape", "dtype", "__getitem__"))


def release_pages(array) -> None:
    """Drop the resident pages of the file `array` maps (if it maps one); they are read again on demand."""
    base = array
    while base is not None and not isinstance(base, mmap.mmap):
        base = getattr(base, "base", None) if isinstance(base, np.ndarray) else getattr(base, "_mmap", None)
    if base is not None and hasattr(mmap, "MADV_DONTNEED"):
        base.madvise(mmap.MADV_DONTNEED)


def read_block(array, slices) -> np.ndarray:
    """A copy of array[slices] in memory, leaving no mapped pages resident behind it."""
    block = np.array(array[slices], copy=True)
    release_pages(array)
    return block
