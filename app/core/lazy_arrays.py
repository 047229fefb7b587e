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


def _mapping(array) -> mmap.mmap | None:
    base = array
    while base is not None and not isinstance(base, mmap.mmap):
        base = getattr(base, "base", None)  # a view's array, a memmap's mmap, a wrapper's array
    return base


def maps_a_file(array) -> bool:
    """Whether `array` is (a view of) a memory-mapped file."""
    return _mapping(array) is not None


def release_pages(array) -> None:
    """Drop the resident pages of the file `array` maps (if it maps one); they are read again on demand."""
    base = _mapping(array)
    if base is not None and hasattr(mmap, "MADV_DONTNEED"):
        base.madvise(mmap.MADV_DONTNEED)


def read_block(array, slices) -> np.ndarray:
    """A copy of array[slices] in memory, leaving no mapped pages resident behind it."""
    block = np.array(array[slices], copy=True)
    release_pages(array)
    return block


class Block3D:
    """A 3-D lazy window on an array of 3 or more axes: fixed indices for its leading axes (an
    OME-Zarr image's time and channel), and optionally its axes reversed (a raw file stored x
    fastest, seen x first).  Read a block at a time (`is_lazy`); np.asarray(it) reads it whole."""

    def __init__(self, base, lead: tuple[int, ...] = (), reverse: bool = False):
        self.base, self.lead, self.reverse = base, tuple(lead), reverse
        shape = tuple(base.shape[len(self.lead):])
        self.shape = shape[::-1] if reverse else shape
        self.dtype = np.dtype(base.dtype)
        self.ndim = 3
        self.size = int(np.prod(self.shape, dtype=np.int64))

    def __getitem__(self, index):
        index = index if isinstance(index, tuple) else (index,)
        index = index + (slice(None),) * (3 - len(index))
        block = np.asarray(self.base[self.lead + (index[::-1] if self.reverse else index)])
        return block.transpose(2, 1, 0) if self.reverse else block

    def __array__(self, dtype=None, copy=None):
        data = np.ascontiguousarray(self[:, :, :])
        return data if dtype is None else data.astype(dtype)

    def __getstate__(self):
        # A whole-file memory map travels (to dask workers) as its file's name, not its data.
        state = dict(self.__dict__)
        base = self.base
        if isinstance(base, np.memmap) and isinstance(base.base, mmap.mmap) and base.filename:
            state["base"] = ("memmap", base.filename, base.dtype.str, base.shape, base.offset)
        return state

    def __setstate__(self, state):
        if isinstance(state["base"], tuple) and state["base"][0] == "memmap":
            _, filename, dtype, shape, offset = state["base"]
            state["base"] = np.memmap(filename, dtype=np.dtype(dtype), mode="r", shape=shape, offset=offset)
        self.__dict__.update(state)
