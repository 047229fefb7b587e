"""NIfTI (.nii, .nii.gz) through nibabel: header zooms for spacing, axis 3 for time.

Only the chosen time point is read, in z slabs through nibabel's array proxy, which
also applies the header's scaling (scaled integers come back as floats).

A compressed series (a 4-D .nii.gz) cannot be read a time point at a time without inflating the
stream up to it, and checking it means inflating it all: so the first read inflates the whole file
once and keeps its bytes (`held`: the last such file, while its size and modification time stay, if
it inflates to at most a quarter of the memory available), and the next time points (the viewer's
playback, `--time all`) are read from them with no gzip pass.
"""
from __future__ import annotations

import gzip
import io
import math
import threading
from pathlib import Path

import numpy as np

from .errors import VolumeError
from .reading import (
    GZIP_CHUNK,
    Loaded,
    inflate_bounded,
    inflated_past,
    library_messages,
    raise_if_corrupt_compression,
    read_in_slabs,
    read_or_explain,
    reason,
)
from .time_points import refuse_time, time_index, time_note
from .volume import Progress, available_memory_bytes, refuse_if_too_big, report, world_problem

HEADER_SLACK = 1 << 20  # bytes a .nii.gz may hold past its data (extensions sit before vox_offset)


def _nibabel_errors() -> tuple[type[Exception], ...]:
    """What nibabel raises for a header it cannot take (several are not ValueErrors)."""
    from nibabel.filebasedimages import ImageFileError
    from nibabel.spatialimages import HeaderDataError, HeaderTypeError, ImageDataError
    from nibabel.wrapstruct import WrapStructError  # a header cut short ("Binary block is wrong size")
    return ImageFileError, HeaderDataError, HeaderTypeError, ImageDataError, WrapStructError


def load_nifti(path: Path, time: int | None, progress: Progress | None = None) -> Loaded:
    """(data, spacing, notes) of a NIfTI file's time point `time` (a 3-D file takes none); nibabel's messages become
    notes."""
    import nibabel  # noqa: F401  (first: its loggers must exist for library_messages to take them)
    notes: list[str] = []
    with library_messages(notes, "nibabel"):
        data, spacing = _load(path, time, notes, progress)
    return data, spacing, notes


def _load(path: Path, time: int | None, notes: list[str], progress: Progress | None):
    if not path.name.lower().endswith(".gz"):
        return _read(path, time, notes, progress, None)[0]
    inflated = held.bytes_of(path) or _inflated_series(path, progress)
    if inflated is not None:   # a series, inflated whole once: its time points read with no gzip pass
        return _read(path, time, notes, progress, io.BytesIO(inflated))[0]
    # One pass through the gzip stream, nibabel reading from it and then the rest read to its end:
    # nibabel alone stops once it has its samples, so a corrupt tail (a failed CRC) would go unseen;
    # and the stream may not inflate past what the header implies (a decompression bomb).
    with open(path, "rb") as compressed, gzip.GzipFile(fileobj=compressed) as stream:
        result, limit = _read(path, time, notes, progress, stream)
        read_or_explain(path, lambda: _read_to_end(stream, limit, path.name))
        if stream.tell() < limit - HEADER_SLACK:
            raise cut_short(path.name, None, stream.tell(), limit - HEADER_SLACK)
    return result


def cut_short(name: str, shape, have: int, needed: int) -> VolumeError:
    """A file that ends before the samples its header promises (a copy or download stopped part-way)."""
    sizes = "" if shape is None else f" ({' x '.join(str(n) for n in shape)})"
    return VolumeError(f"{name} ends after {have:,} bytes, but its header{sizes} needs {needed:,}: it was cut "
                       "off; copy or export it again")


class HeldSeries:
    """The inflated bytes of the last compressed series read, with the (size, mtime) they were read at."""

    def __init__(self):
        self._lock = threading.Lock()   # the viewer reads time points on a worker thread
        self._key = None
        self._bytes: bytes | None = None
        self.inflations = 0   # whole-file gzip passes made to fill it (a count to read, for tests and benchmarks)

    @staticmethod
    def key(path: Path):
        """What identifies the file's bytes: its resolved path, size and modification time."""
        stat = path.stat()
        return str(path.resolve()), stat.st_size, stat.st_mtime_ns

    def bytes_of(self, path: Path) -> bytes | None:
        """The file's inflated bytes if held and the file has not changed since."""
        try:
            key = self.key(path)
        except OSError:
            return None
        with self._lock:
            return self._bytes if key == self._key else None

    def hold(self, path: Path, key, inflated: bytes) -> None:
        """Keep `inflated`, the bytes of the series at `path` read under `key`, in place of those held before."""
        with self._lock:
            self._key, self._bytes = key, inflated
            self.inflations += 1

    def release(self) -> None:
        """Drop the bytes held."""
        with self._lock:
            self._key = self._bytes = None


held = HeldSeries()
HELD_SHARE = 4   # a series is held if it inflates to at most 1/HELD_SHARE of the memory available


def _inflated_series(path: Path, progress: Progress | None) -> bytes | None:
    """A compressed 4-D file's whole inflated stream (kept in `held`), one pass; None for anything else
    (a 3-D file, one time point, too big to hold, a header that does not parse: the plain read says why)."""
    import nibabel
    try:
        key = held.key(path)
        with gzip.open(path, "rb") as stream:
            head = stream.read(544)
        nifti2 = head[:4] in (b"\x1c\x02\x00\x00", b"\x00\x00\x02\x1c")
        header = (nibabel.Nifti2Header if nifti2 else nibabel.Nifti1Header).from_fileobj(io.BytesIO(head))
        shape = tuple(int(n) for n in header.get_data_shape())
        offset = int(header.get("vox_offset", 352))
        size = math.prod(shape) * header.get_data_dtype().itemsize
    except Exception:   # noqa: BLE001 - the plain read says what is wrong with it
        return None
    if len(shape) < 4 or shape[3] < 2 or min(shape) < 1:
        return None
    limit = offset + size + HEADER_SLACK
    if limit > available_memory_bytes() // HELD_SHARE:
        return None   # read a time point at a time, as before
    report(progress, 0.0, f"inflating {path.name}")
    with open(path, "rb") as compressed:
        inflated = read_or_explain(path, lambda: inflate_bounded(compressed, limit, path.name))
    if len(inflated) < offset + size:
        return None   # short (or several gzip members): the plain read through GzipFile says which
    held.hold(path, key, inflated)
    return inflated


def _read_to_end(stream, limit: int, what: str) -> None:
    """Read a gzip stream to its end (checking its CRC and length), refusing it past `limit` bytes."""
    while stream.read(GZIP_CHUNK):
        if stream.tell() > limit:
            raise inflated_past(what, limit)


def _read(path: Path, time: int | None, notes: list[str], progress: Progress | None, stream):
    """((data, spacing), the most bytes the file's stream may hold) of the file, or of `stream` (its
    uncompressed contents) where given."""
    import nibabel
    try:
        if stream is None:
            image = nibabel.load(str(path))
        else:
            size_of_header = stream.read(4)
            stream.seek(0)
            nifti2 = size_of_header in (b"\x1c\x02\x00\x00", b"\x00\x00\x02\x1c")  # 540, either byte order
            image = (nibabel.Nifti2Image if nifti2 else nibabel.Nifti1Image).from_stream(stream)
        shape = tuple(int(n) for n in image.shape)
        zooms = tuple(float(z) for z in image.header.get_zooms())
    except (*_nibabel_errors(), OSError, EOFError, ValueError, OverflowError) as exc:
        _raise_if_broken_gzip(path)
        raise VolumeError(f"{path.name} is not a readable NIfTI file ({reason(exc)}); check the file") from None
    except Exception as exc:
        raise_if_corrupt_compression(exc, path)
        raise
    if image.header.get_data_dtype().fields is not None:
        raise VolumeError(f"{path.name} holds colour samples ({', '.join(image.header.get_data_dtype().names)} "
                          "per voxel); a volume needs one value per voxel: save one channel")
    if any(n < 0 for n in shape):
        raise VolumeError(f"{path.name}'s header gives the shape {shape}, with a negative size; the file is "
                          "damaged: export it again")
    offset = float(image.header.get("vox_offset", 352))
    available = path.stat().st_size if stream is None else None
    if not 0 <= offset <= (available if available is not None else 2**62):
        raise VolumeError(f"{path.name}'s header puts its samples at byte {offset:g}, outside the file; the file "
                          "is damaged or truncated: export it again")
    needed = int(offset) + math.prod(shape) * image.header.get_data_dtype().itemsize
    scaled = getattr(image.dataobj, "slope", 1.0) != 1.0 or getattr(image.dataobj, "inter", 0.0) != 0.0
    itemsize = 8 if scaled else image.header.get_data_dtype().itemsize
    limit = needed + HEADER_SLACK
    if len(shape) < 3 or any(n != 1 for n in shape[4:]):
        # Not a volume or a series of them: read it so the common checks can say what it is.
        refuse_if_too_big(shape, itemsize, path.name)
        refuse_time(time, path.name, len(shape))
        return (read_or_explain(path, lambda: np.asarray(image.dataobj)), None), limit
    refuse_if_too_big(shape[:3], itemsize, path.name)
    if available is not None and available < needed:   # a 4-D file cut short: its first time points read fine
        raise cut_short(path.name, shape, available, needed)
    which = ()
    if len(shape) >= 4:
        index = time_index(time, shape[3], path.name)
        notes.append(time_note(index, shape[3]))
        which = (index,) + (0,) * (len(shape) - 4)
    else:
        refuse_time(time, path.name, len(shape))
    report(progress, 0.0, f"reading {path.name}")
    # z is slowest in the file: z slabs keep the reads sequential, even through gzip.
    data = read_or_explain(path, lambda: read_in_slabs(
        lambda slab: np.asarray(image.dataobj[slab + which]), shape[:3], 2, path.name, progress))
    return (data, zooms[:3] if len(zooms) >= 3 else None), limit


def nifti_world(path: Path):
    """(4x4 array index -> RAS millimetres, "RAS") from the header's sform, else its qform, whichever
    is set and usable (a zeroed sform is skipped, as ITK does); nibabel's own choice otherwise."""
    import nibabel
    with library_messages([], "nibabel"):  # load_nifti already kept its messages
        try:
            image = nibabel.load(str(path))
            for matrix, code in (image.header.get_sform(coded=True), image.header.get_qform(coded=True)):
                if code and world_problem(matrix) is None:
                    return np.asarray(matrix, np.float64), "RAS"
            return np.asarray(image.affine, np.float64), "RAS"
        except (*_nibabel_errors(), OSError, EOFError, ValueError, np.linalg.LinAlgError):
            return None  # no usable orientation: index x spacing (the samples were read)


def nifti_unit(path: Path) -> str | None:
    """The spatial unit the header's xyzt_units states ("micron", "meter"; "millimeter" for mm), or None where it
    states none ("unknown", or a header nibabel cannot read again)."""
    import nibabel

    from ..core.units import length_unit_name
    with library_messages([], "nibabel"):
        try:
            unit = nibabel.load(str(path)).header.get_xyzt_units()[0]
        except (*_nibabel_errors(), OSError, EOFError, ValueError, KeyError):
            return None
    return length_unit_name(unit)


def _raise_if_broken_gzip(path: Path) -> None:
    """nibabel reports a cut-off .gz as an unknown file type; say what is really wrong."""
    if not path.name.lower().endswith(".gz"):
        return
    import gzip
    import zlib
    try:
        with gzip.open(path) as stream:
            stream.read(1 << 16)
    except (EOFError, OSError, zlib.error) as exc:
        raise VolumeError(f"{path.name} is a corrupt or truncated gzip file ({reason(exc)}); "
                          f"download or export it again") from None
