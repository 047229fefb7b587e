"""What every file loader shares: reading in slabs with progress, and wording read failures."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import VolumeError
from .volume import Progress, report

# What a loader hands back before the common checks: the array (3-D or 4-D),
# the spacing of the three spatial axes (None: the header has none), and notes.
Loaded = tuple[np.ndarray, "tuple[float, float, float] | None", list[str]]

SLAB_BYTES = 32 << 20  # per read: big enough to be fast, small enough for a moving bar
MAP_BYTES = 256 << 20  # .npy and raw files this big are memory-mapped, not read: they may not fit in memory


def read_in_slabs(read, shape, axis: int, what: str, progress: Progress | None) -> np.ndarray:
    """A new array filled by read(index) over slabs along one axis, reporting progress.

    Slabbing along the axis the file stores slowest keeps each read contiguous.
    The array takes the dtype of the first slab (a scaled NIfTI reads as float).
    """
    out, start, step = None, 0, 1  # one plane first, to learn the dtype; then ~SLAB_BYTES at a time
    plane_voxels = max(1, int(np.prod(shape, dtype=np.float64)) // shape[axis])
    while start < shape[axis]:
        index = [slice(None)] * len(shape)
        index[axis] = slice(start, min(start + step, shape[axis]))
        slab = read(tuple(index))
        if out is None:
            out = np.empty(shape, dtype=slab.dtype)
            step = max(1, SLAB_BYTES // (plane_voxels * slab.dtype.itemsize))
        out[tuple(index)] = slab
        start = index[axis].stop
        report(progress, start / shape[axis], f"reading {what}")
    return out


def read_or_explain(path: Path, read, errors: tuple[type[BaseException], ...] = ()):
    """read(), with a failure turned into a one-line VolumeError about `path`: `errors` and
    OS/EOF/value errors say the file is damaged, cut-off compression says so."""
    try:
        return read()
    except (OSError, EOFError, ValueError, *errors) as exc:
        raise damaged(path, exc) from None
    except Exception as exc:
        raise_if_corrupt_compression(exc, path)
        raise


def raise_if_corrupt_compression(exc: Exception, path: Path) -> None:
    # zlib.error is not an OSError; it is what a corrupt deflate stream raises.
    if type(exc).__module__ in ("zlib", "_bz2", "bz2", "gzip"):
        raise VolumeError(f"{path.name}: its compressed data is corrupt ({exc}); export it again") from None


def reason(exc: Exception) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text if len(text) < 160 else text[:157] + "..."


def damaged(path: Path, exc: Exception, fix: str = "export it again") -> VolumeError:
    return VolumeError(f"{path.name} is damaged or truncated ({reason(exc)}); {fix}")
