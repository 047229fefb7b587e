"""numpy's .npy and .npz files, read without ever unpickling.

The header is parsed first, so object (pickled) arrays and shapes too big for
memory are refused before a byte of data is read. 4-D arrays are stacks of
volumes, frames along axis 0 (np.stack(volumes)); the caller picks one.
"""
from __future__ import annotations

import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

from .errors import VolumeError
from .reading import MAP_BYTES, SLAB_BYTES, Loaded, damaged, read_in_slabs
from .volume import Progress, refuse_if_too_big, report

_RESAVE = "save it again with np.save"


def read_header(fp, what: str, file_bytes: int | None = None) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from an .npy header; refuses pickles and monsters.

    With `file_bytes` (the file's size), a C-ordered array the file wholly holds may be larger
    than memory: load_npy maps it instead of reading it."""
    try:
        version = np.lib.format.read_magic(fp)
        read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, fortran_order, dtype = read(fp)
    except (ValueError, SyntaxError, tokenize.TokenError) as exc:  # a cut-off header dict fails to tokenize
        raise VolumeError(f"{what} is not a valid .npy file ({exc}); {_RESAVE}") from None
    if dtype.hasobject:
        raise VolumeError(f"{what} holds Python objects (a pickled array), which isoscope never "
                          f"loads; save a numeric array with np.save(path, a.astype(np.float32))")
    whole = file_bytes is not None and fp.tell() + np.prod(shape, dtype=np.float64) * dtype.itemsize <= file_bytes
    if not (whole and not fortran_order and len(shape) >= 3):
        refuse_if_too_big(shape, dtype.itemsize, what)
    return shape, dtype


def load_npy(path: Path, progress: Progress | None = None, map_file: bool = False) -> Loaded:
    """Small files are read; a C-ordered one of MAP_BYTES or more (with `map_file`, of any size) is
    memory-mapped, read on demand (it may exceed RAM)."""
    with open(path, "rb") as fp:
        shape, dtype = read_header(fp, path.name, path.stat().st_size)
    report(progress, 0.0, f"reading {path.name}")
    try:
        n_bytes = np.prod(shape, dtype=np.float64) * dtype.itemsize
        if len(shape) < 3 or (n_bytes < min(SLAB_BYTES, MAP_BYTES) and not map_file):
            return np.load(path, allow_pickle=False), None, []
        mapped = np.load(path, mmap_mode="r", allow_pickle=False)
        if mapped.flags.c_contiguous and (n_bytes >= MAP_BYTES or map_file):
            return mapped, None, [f"{path.name} is memory-mapped: read from disk as needed"]
        # Fortran order: copy it slab by slab into C order, so the progress bar moves.
        slab_axis = len(shape) - 1 if mapped.flags.f_contiguous and not mapped.flags.c_contiguous else 0
        return read_in_slabs(lambda index: mapped[index], shape, slab_axis, path.name, progress), None, []
    except (ValueError, EOFError, OSError) as exc:
        raise damaged(path, exc, _RESAVE) from None


def load_npz(path: Path, array_name: str | None, progress: Progress | None = None) -> Loaded:
    """The named array of an .npz (default: the first); never unpickles."""
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
        try:
            with archive.open(name + ".npy") as member:
                read_header(member, f"{path.name}:{name}")
            with archive.open(name + ".npy") as member:  # zip members cannot seek back
                data = np.lib.format.read_array(member, allow_pickle=False)
        except VolumeError:
            raise
        except (ValueError, EOFError, OSError, zipfile.BadZipFile, zlib.error) as exc:
            raise damaged(path, exc, "save it again with np.savez") from None
    notes = [f"{path.name} holds {len(members)} arrays; showing {name!r} (pick one as {path.name}:NAME)"] \
        if len(members) > 1 and array_name is None else []
    return data, None, notes
