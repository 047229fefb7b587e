"""NIfTI (.nii, .nii.gz) through nibabel: header zooms for spacing, axis 3 for time.

Only the chosen frame is read, in z slabs through nibabel's array proxy, which
also applies the header's scaling (scaled integers come back as floats).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import VolumeError
from .frames import frame_index, frame_note, refuse_frame
from .reading import (
    Loaded,
    check_gzip_file,
    library_messages,
    raise_if_corrupt_compression,
    read_in_slabs,
    read_or_explain,
    reason,
)
from .volume import Progress, refuse_if_too_big, report, world_problem

HEADER_SLACK = 1 << 20  # bytes a .nii.gz may hold past its data (extensions sit before vox_offset)


def load_nifti(path: Path, frame: int | None, progress: Progress | None = None) -> Loaded:
    import nibabel  # noqa: F401  (first: its loggers must exist for library_messages to take them)
    notes: list[str] = []
    with library_messages(notes, "nibabel"):
        data, spacing = _load(path, frame, notes, progress)
    return data, spacing, notes


def _load(path: Path, frame: int | None, notes: list[str], progress: Progress | None):
    import nibabel
    from nibabel.filebasedimages import ImageFileError
    try:
        image = nibabel.load(str(path))
        shape = tuple(int(n) for n in image.shape)
        zooms = tuple(float(z) for z in image.header.get_zooms())
    except (ImageFileError, OSError, EOFError, ValueError) as exc:
        _raise_if_broken_gzip(path)
        raise VolumeError(f"{path.name} is not a readable NIfTI file ({reason(exc)}); check the file") from None
    except Exception as exc:
        raise_if_corrupt_compression(exc, path)
        raise
    scaled = getattr(image.dataobj, "slope", 1.0) != 1.0 or getattr(image.dataobj, "inter", 0.0) != 0.0
    itemsize = 8 if scaled else image.header.get_data_dtype().itemsize
    if path.name.lower().endswith(".gz"):
        # nibabel stops reading once it has its samples, so a corrupt tail (a failed CRC) would go
        # unseen, and a gzip body may inflate far past what the header says: read it to its end first.
        stored = math.prod(shape) * image.header.get_data_dtype().itemsize
        check_gzip_file(path, int(image.header.get("vox_offset", 352)) + stored + HEADER_SLACK)
    if len(shape) < 3 or any(n != 1 for n in shape[4:]):
        # Not a volume or a series of them: read it so the common checks can say what it is.
        refuse_if_too_big(shape, itemsize, path.name)
        refuse_frame(frame, path.name, len(shape))
        return read_or_explain(path, lambda: np.asarray(image.dataobj)), None
    refuse_if_too_big(shape[:3], itemsize, path.name)
    which = ()
    if len(shape) >= 4:
        index = frame_index(frame, shape[3], path.name)
        notes.append(frame_note(index, shape[3]))
        which = (index,) + (0,) * (len(shape) - 4)
    else:
        refuse_frame(frame, path.name, len(shape))
    report(progress, 0.0, f"reading {path.name}")
    # z is slowest in the file: z slabs keep the reads sequential, even through gzip.
    data = read_or_explain(path, lambda: read_in_slabs(
        lambda slab: np.asarray(image.dataobj[slab + which]), shape[:3], 2, path.name, progress))
    return data, zooms[:3] if len(zooms) >= 3 else None


def nifti_world(path: Path):
    """(4x4 array index -> RAS millimetres, "RAS") from the header's sform, else its qform, whichever
    is set and usable (a zeroed sform is skipped, as ITK does); nibabel's own choice otherwise."""
    import nibabel
    with library_messages([], "nibabel"):  # load_nifti already kept its messages
        image = nibabel.load(str(path))
        for matrix, code in (image.header.get_sform(coded=True), image.header.get_qform(coded=True)):
            if code and world_problem(matrix) is None:
                return np.asarray(matrix, np.float64), "RAS"
        return np.asarray(image.affine, np.float64), "RAS"


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
