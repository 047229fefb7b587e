"""Reading volume files: .npy, .npz, NRRD, NIfTI and raw binary.

Every loader reads the header first and refuses, before allocating, a volume
that cannot fit in memory; then it returns the array with axis 0 as x and the
spacing the header gives. Library exceptions become one-line VolumeErrors.
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from .errors import VolumeError
from .volume import Progress, refuse_if_too_big, report, shape_text

# What a loader hands back before the common checks: the array (3-D or 4-D),
# the spacing of the three spatial axes (None: the header has none), and notes.
Loaded = tuple[np.ndarray, "tuple[float, float, float] | None", list[str]]


def _npy_header(fp, what: str) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from an .npy header, refusing pickles and monsters before reading data."""
    try:
        version = np.lib.format.read_magic(fp)
        if version == (1, 0):
            shape, fortran_order, dtype = np.lib.format.read_array_header_1_0(fp)
        else:
            shape, fortran_order, dtype = np.lib.format.read_array_header_2_0(fp)
    except ValueError as exc:
        raise VolumeError(f"{what} is not a valid .npy file ({exc}); save it with np.save") from None
    if dtype.hasobject:
        raise VolumeError(f"{what} holds Python objects (a pickled array), which isoscope never "
                          f"loads; save a numeric array with np.save(path, a.astype(np.float32))")
    refuse_if_too_big(shape, dtype.itemsize, what)
    return shape, dtype


def _read_npy_member(fp, what: str) -> np.ndarray:
    _npy_header(fp, what)
    fp.seek(0)
    try:
        return np.lib.format.read_array(fp, allow_pickle=False)
    except (ValueError, EOFError, OSError, zipfile.BadZipFile) as exc:
        raise VolumeError(f"{what} is damaged or truncated ({exc}); save it again with np.save") from None


def load_npy(path: Path, progress: Progress | None = None) -> Loaded:
    with open(path, "rb") as fp:
        shape, dtype = _npy_header(fp, path.name)
    report(progress, 0.0, f"reading {path.name}")
    if len(shape) < 3 or np.prod(shape, dtype=np.float64) * dtype.itemsize < _SLAB_BYTES:
        with open(path, "rb") as fp:
            return _read_npy_member(fp, path.name), None, []
    # Big: map the file and copy it slab by slab, so the progress bar moves.
    try:
        mapped = np.load(path, mmap_mode="r", allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise VolumeError(f"{path.name} is damaged or truncated ({_reason(exc)}); save it again with np.save") from None
    slab_axis = len(shape) - 1 if mapped.flags.f_contiguous and not mapped.flags.c_contiguous else 0
    data = read_in_slabs(lambda index: mapped[index], shape, slab_axis, path.name, progress)
    return data, None, []


_SLAB_BYTES = 32 << 20


def read_in_slabs(read, shape, axis: int, what: str, progress: Progress | None) -> np.ndarray:
    """A new array filled by read(index) over slabs along one axis, reporting progress.

    Slabbing along the axis the file stores slowest keeps each read contiguous.
    The array takes the dtype of the first slab (a scaled NIfTI reads as float).
    """
    out, start, step = None, 0, 1  # one plane first, to learn the dtype; then ~_SLAB_BYTES at a time
    plane_voxels = max(1, int(np.prod(shape, dtype=np.float64)) // shape[axis])
    while start < shape[axis]:
        index = [slice(None)] * len(shape)
        index[axis] = slice(start, min(start + step, shape[axis]))
        slab = read(tuple(index))
        if out is None:
            out = np.empty(shape, dtype=slab.dtype)
            step = max(1, _SLAB_BYTES // (plane_voxels * slab.dtype.itemsize))
        out[tuple(index)] = slab
        start = index[axis].stop
        report(progress, start / shape[axis], f"reading {what}")
    return out


def load_npz(path: Path, array_name: str | None, progress: Progress | None = None) -> Loaded:
    try:
        archive = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise VolumeError(f"{path.name} is not a valid .npz (zip) file; save it with np.savez") from None
    with archive:
        members = [m[:-4] for m in archive.namelist() if m.endswith(".npy")]
        if not members:
            raise VolumeError(f"{path.name} holds no arrays; save one with np.savez(path, volume=a)")
        name = array_name if array_name is not None else members[0]
        if name not in members:
            raise VolumeError(f"{path.name} has no array named {name!r}; it has "
                              f"{', '.join(members)} (pick one as {path.name}:NAME)")
        report(progress, 0.0, f"reading {path.name}:{name}")
        what = f"{path.name}:{name}"
        try:
            with archive.open(name + ".npy") as member:
                _npy_header(member, what)  # refuse pickles and monsters before reading data
            with archive.open(name + ".npy") as member:
                data = np.lib.format.read_array(member, allow_pickle=False)
        except (ValueError, EOFError, OSError, zipfile.BadZipFile) as exc:
            if isinstance(exc, VolumeError):
                raise
            raise VolumeError(f"{what} is damaged or truncated ({exc}); save it again with np.savez") from None
    notes = [f"{path.name} holds {len(members)} arrays; showing {name!r} (pick one as {path.name}:NAME)"] \
        if len(members) > 1 and array_name is None else []
    return data, None, notes


# --- NRRD ------------------------------------------------------------------------------

_NRRD_DOMAIN_KINDS = {"domain", "space"}


def _nrrd_itemsize(type_name: str) -> int:
    """Bytes per sample from an NRRD "type" (only for the size check before reading)."""
    name = type_name.lower()
    if "char" in name or name.endswith("int8") or name.endswith("int8_t"):
        return 1
    if "short" in name or "16" in name:
        return 2
    if "long" in name or "64" in name or name == "double":
        return 8
    return 4


def _nrrd_spacing(header: dict, spatial_axes: list[int]):
    if "spacings" in header:
        values = [float(header["spacings"][a]) for a in spatial_axes]
    elif header.get("space directions") is not None:
        directions = header["space directions"]
        values = [float(np.linalg.norm(directions[a])) for a in spatial_axes]
    else:
        return None
    return tuple(values) if all(np.isfinite(v) and v > 0 for v in values) else None


def load_nrrd(path: Path, frame: int | None, progress: Progress | None = None) -> Loaded:
    import nrrd
    try:
        header = nrrd.read_header(str(path))
    except (nrrd.NRRDError, OSError, ValueError, UnicodeDecodeError) as exc:
        raise VolumeError(f"{path.name} has no valid NRRD header ({exc}); check the file") from None
    sizes = [int(s) for s in header.get("sizes", [])]
    if header.get("type") == "block":
        raise VolumeError(f"{path.name} holds NRRD 'block' samples, not numbers; save a numeric type")
    refuse_if_too_big(sizes, _nrrd_itemsize(str(header.get("type", "double"))), path.name)
    report(progress, 0.0, f"reading {path.name}")
    try:
        data, header = nrrd.read(str(path))  # index order F: data[x, y, z(, t)], axis 0 is x
    except (nrrd.NRRDError, OSError, EOFError, ValueError) as exc:
        raise VolumeError(f"{path.name} is damaged or truncated ({_reason(exc)}); export it again") from None
    except Exception as exc:
        _raise_if_corrupt_compression(exc, path)
        raise
    notes: list[str] = []
    spatial_axes = list(range(data.ndim))
    if data.ndim == 4:
        kinds = [str(k).lower() for k in header.get("kinds", [])]
        frame_axis = next((a for a, k in enumerate(kinds) if k not in _NRRD_DOMAIN_KINDS), 3)
        data, notes = select_frame(data, frame_axis, frame, path.name)
        spatial_axes.remove(frame_axis)
    spacing = _nrrd_spacing(header, spatial_axes) if len(spatial_axes) == 3 else None
    return data, spacing, notes


# --- NIfTI -----------------------------------------------------------------------------

def load_nifti(path: Path, frame: int | None, progress: Progress | None = None) -> Loaded:
    import nibabel
    from nibabel.filebasedimages import ImageFileError
    try:
        image = nibabel.load(str(path))
        shape = tuple(int(n) for n in image.shape)
        dtype = image.header.get_data_dtype()
        zooms = tuple(float(z) for z in image.header.get_zooms())
    except (ImageFileError, OSError, EOFError, ValueError) as exc:
        _raise_if_broken_gzip(path)
        raise VolumeError(f"{path.name} is not a readable NIfTI file ({_reason(exc)}); check the file") from None
    except Exception as exc:
        _raise_if_corrupt_compression(exc, path)
        raise
    itemsize = max(dtype.itemsize, 4 if _nifti_scaled(image) else 1)  # scaled data comes back as float
    notes: list[str] = []
    if len(shape) < 3 or any(n != 1 for n in shape[4:]):
        # Not a volume or a series of them: read it so the common checks can say what it is.
        refuse_if_too_big(shape, itemsize, path.name)
        _refuse_frame(frame, path.name, len(shape))
        return _read_nifti(path, lambda: np.asarray(image.dataobj)), None, notes
    refuse_if_too_big(shape[:3], itemsize, path.name)
    frame_index: tuple[int, ...] = ()
    if len(shape) >= 4:
        index = _frame_index(frame, shape[3], path.name)
        notes.append(_frame_note(path.name, index, shape[3]))
        frame_index = (index,) + (0,) * (len(shape) - 4)
    else:
        _refuse_frame(frame, path.name, len(shape))
    report(progress, 0.0, f"reading {path.name}")
    # Slicing the proxy reads only what is asked for and applies the header's scaling;
    # slabs along z (slowest in the file) keep the reads sequential, even through gzip.
    data = _read_nifti(path, lambda: read_in_slabs(
        lambda slab: np.asarray(image.dataobj[slab + frame_index]), shape[:3], 2, path.name, progress))
    return data, zooms[:3] if len(zooms) >= 3 else None, notes


def _read_nifti(path: Path, read):
    try:
        return read()
    except (OSError, EOFError, ValueError) as exc:
        raise VolumeError(f"{path.name} is damaged or truncated ({_reason(exc)}); export it again") from None
    except Exception as exc:
        _raise_if_corrupt_compression(exc, path)
        raise


def _nifti_scaled(image) -> bool:
    slope, inter = getattr(image.dataobj, "slope", 1.0), getattr(image.dataobj, "inter", 0.0)
    return not (slope in (1.0, None) or np.isnan(slope)) or not (inter in (0.0, None) or np.isnan(inter))


def _raise_if_corrupt_compression(exc: Exception, path: Path) -> None:
    # zlib.error is not an OSError; it is what a corrupt deflate stream raises.
    if type(exc).__module__ in ("zlib", "_bz2", "bz2", "gzip"):
        raise VolumeError(f"{path.name}: its compressed data is corrupt ({exc}); export it again") from None


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
        raise VolumeError(f"{path.name} is a corrupt or truncated gzip file ({_reason(exc)}); "
                          f"download or export it again") from None


def _reason(exc: Exception) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text if len(text) < 160 else text[:157] + "..."


# --- 4-D data ----------------------------------------------------------------------------

def _frame_index(frame: int | None, n_frames: int, what: str) -> int:
    index = 0 if frame is None else int(frame)
    if not 0 <= index < n_frames:
        raise VolumeError(f"--frame {frame} is out of range: {what} has {n_frames} frames "
                          f"(use --frame 0..{n_frames - 1})")
    return index


def _frame_note(what: str, index: int, n_frames: int) -> str:
    return f"4-D file: showing frame {index} of {n_frames} (use --frame N)"


def _refuse_frame(frame: int | None, what: str, ndim: int) -> None:
    if frame is not None and ndim == 3:
        raise VolumeError(f"--frame {frame} given but {what} is 3-D (a single frame); drop --frame")


def select_frame(data: np.ndarray, frame_axis: int, frame: int | None, what: str):
    """One 3-D volume out of a 4-D array; (array, notes). 3-D arrays pass through."""
    if data.ndim != 4:
        _refuse_frame(frame, what, data.ndim)
        return data, []
    index = _frame_index(frame, data.shape[frame_axis], what)
    return np.take(data, index, axis=frame_axis), [_frame_note(what, index, data.shape[frame_axis])]
