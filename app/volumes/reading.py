"""What every file loader shares: reading in slabs with progress, and wording read failures."""
from __future__ import annotations

import contextlib
import logging
import threading
import warnings
import zlib
from pathlib import Path

import numpy as np

from ..core.opener import UnreadablePath, regular_file
from .errors import VolumeError
from .volume import Progress, report

# What a loader hands back before the common checks: the array (3-D or 4-D),
# the spacing of the three spatial axes (None: the header has none), and notes.
Loaded = tuple[np.ndarray, "tuple[float, float, float] | None", list[str]]

SLAB_BYTES = 32 << 20  # per read: big enough to be fast, small enough for a moving bar
MAP_BYTES = 256 << 20  # .npy and raw files this big are memory-mapped, not read: they may not fit in memory


def maps_within(spec, budget_bytes: int | None) -> bool:
    """Whether to memory-map `spec` (a raw file or a C-ordered .npy) rather than read it, for a viewer whose memory
    budget is `budget_bytes`: where the file takes more than half the budget, reading it whole would spend
    the budget before a surface is made (a volume over it is shown in bricks, read a block at a time)."""
    if budget_bytes is None or not isinstance(spec, str) or not Path(spec).is_file():
        return False
    return Path(spec).stat().st_size > budget_bytes // 2


def read_in_slabs(read, shape, axis: int, what: str, progress: Progress | None) -> np.ndarray:
    """A new array filled by read(index) over slabs along one axis, reporting progress.

    Slabbing along the axis the file stores slowest keeps each read contiguous; slabs along the last axis
    (a NIfTI's z, a Fortran-ordered .npy) fill an array in Fortran order, the file's own, so each slab is
    one contiguous copy, not a transpose (the extractors read any order in place).
    The array takes the dtype of the first slab (a scaled NIfTI reads as float).
    """
    if 0 in tuple(shape):  # nothing to read: the common checks say what is wrong with its shape
        return np.asarray(read(tuple(slice(None) for _ in shape)))
    out, start, step = None, 0, 1  # one plane first, to learn the dtype; then ~SLAB_BYTES at a time
    plane_voxels = max(1, int(np.prod(shape, dtype=np.float64)) // shape[axis])
    while start < shape[axis]:
        index = [slice(None)] * len(shape)
        index[axis] = slice(start, min(start + step, shape[axis]))
        slab = read(tuple(index))
        if out is None:
            out = np.empty(shape, dtype=slab.dtype, order="F" if axis == len(shape) - 1 else "C")
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
    except VolumeError:  # already one line about the file
        raise
    except (OSError, EOFError, ValueError, OverflowError, *errors) as exc:  # OverflowError: an mmap or
        raise damaged(path, exc) from None                                    # a count past what C takes
    except Exception as exc:
        raise_if_corrupt_compression(exc, path)
        raise


def raise_if_corrupt_compression(exc: Exception, path: Path) -> None:
    """Raise a VolumeError naming `path` if `exc` comes from a corrupt compressed stream (zlib, bz2, gzip); otherwise
    return."""
    # zlib.error is not an OSError; it is what a corrupt deflate stream raises.
    if type(exc).__module__ in ("zlib", "_bz2", "bz2", "gzip"):
        raise VolumeError(f"{path.name}: its compressed data is corrupt ({exc}); export it again") from None


def reason(exc: Exception) -> str:
    """`exc` in a few words for a message: its text (or its type's name), cut at 160 characters."""
    text = str(exc).strip() or type(exc).__name__
    return text if len(text) < 160 else text[:157] + "..."


def damaged(path: Path, exc: Exception, fix: str = "export it again") -> VolumeError:
    """The VolumeError of a damaged or truncated file: its name, the reason and `fix`."""
    return VolumeError(f"{path.name} is damaged or truncated ({reason(exc)}); {fix}")


def refuse_unless_regular(path: Path, what: str | None = None) -> None:
    """Through the one opener (core/opener.py): a pipe, socket or device would block a read or never end, so
    only regular files are read; an empty one holds no volume, whatever its name says."""
    try:
        regular_file(path, what or "the volume", empty_ok=False)
    except UnreadablePath as exc:
        raise VolumeError(str(exc)) from None


GZIP_CHUNK = 1 << 20


def inflate_bounded(stream, limit: int, what: str, decompressor=None) -> bytes:
    """The whole of a gzip (default) or bzip2 stream read from `stream`, checked to its end (CRC, length).

    Refuses, while inflating, a stream that would give more than `limit` bytes: a few kilobytes
    of deflate can claim gigabytes (a decompression bomb), and the header already said how much
    data there is. A stream that ends early, is corrupt or fails its CRC is refused too."""
    inflate = decompressor if decompressor is not None else zlib.decompressobj(zlib.MAX_WBITS | 32)  # gzip or zlib
    out = bytearray()
    try:
        while not inflate.eof:
            chunk = inflate.unconsumed_tail if getattr(inflate, "unconsumed_tail", b"") else stream.read(GZIP_CHUNK)
            if not chunk:
                raise VolumeError(f"{what}: its compressed data ends early (truncated); export it again")
            out += inflate.decompress(chunk, limit + 1 - len(out))
            if len(out) > limit:
                raise inflated_past(what, limit)
    except (zlib.error, OSError, EOFError) as exc:
        raise VolumeError(f"{what}: its compressed data is corrupt ({reason(exc)}); export it again") from None
    return bytes(out)


def inflated_past(what: str, limit: int) -> VolumeError:
    """The refusal of compressed data that inflates past what its header implies."""
    return VolumeError(f"{what}: its compressed data inflates to more than the {limit:,} bytes its header "
                       "implies (corrupt, or a decompression bomb); export it again")


@contextlib.contextmanager
def library_messages(notes: list[str], *loggers: str):
    """Warnings and log records that a reading library prints (nibabel's pixdim notice, tifffile's
    page offsets, numpy's overflow), kept as the volume's notes instead: stderr stays isoscope's.

    Import the library first: the loggers it makes on import are the ones taken. Warnings are taken
    on the main thread only: the warnings filters are process-wide, and a loader thread (the viewer's)
    must not swallow the main thread's; there they go where Python sends them."""
    records: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record.getMessage())

    handler, saved = Keep(logging.WARNING), []
    named = [name for name in list(logging.Logger.manager.loggerDict)
             if any(name == root or name.startswith(root + ".") for root in loggers)]  # nibabel.global has its own
    for name in dict.fromkeys([*loggers, *named]):
        logger = logging.getLogger(name)
        saved.append((logger, logger.propagate, list(logger.handlers)))
        logger.handlers, logger.propagate = [handler], False
    caught: list = []
    try:
        if threading.current_thread() is threading.main_thread():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                yield
        else:
            yield
    finally:
        for logger, propagate, handlers in saved:
            logger.handlers, logger.propagate = handlers, propagate
    for message in records + [str(w.message) for w in caught]:
        line = " ".join(message.split())
        if line and line not in notes:
            notes.append(line)
