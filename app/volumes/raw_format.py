"""Raw binary volumes: no header, so the layout comes from flags or a JSON sidecar.

Layout is x fastest (ParaView's raw reader, the CUDA sample's Bucky.raw): the
file is a C-order (z, y, x) array, transposed here so axis 0 is x.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.lazy_arrays import Block3D
from ..core.opener import UnreadablePath, read_text
from .errors import VolumeError
from .reading import MAP_BYTES
from .volume import Progress, refuse_if_too_big, report, shape_text, size_text

RAW_DTYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")
ENDIANS = {"little": "<", "big": ">"}
SIDECAR_KEYS = ("dims", "dtype", "endian", "spacing")
_READ_CHUNK = 32 << 20
MAX_DIM = (1 << 31) - 1  # samples per axis: more is no file anyone has (and wraps 32-bit indices)


@dataclass
class RawLayout:
    """How a raw file's bytes are laid out: its dimensions, sample type, spacing (None: not given) and notes."""
    dims: tuple[int, int, int]
    dtype: np.dtype
    spacing: tuple[float, float, float] | None
    notes: list[str]


def sidecar_path(path: Path) -> Path | None:
    """The JSON sidecar beside a raw file (NAME.raw.json, else NAME.json), or None."""
    for candidate in (path.with_name(path.name + ".json"), path.with_suffix(".json")):
        if candidate.is_file() and candidate != path:
            return candidate
    return None


MAX_SIDECAR_BYTES = 64 << 10   # a few keys: a sidecar is under a kilobyte


def _read_sidecar(path: Path) -> dict:
    try:
        keys = json.loads(read_text(path, "the sidecar", MAX_SIDECAR_BYTES))
    except UnreadablePath as exc:
        raise VolumeError(str(exc)) from None
    except (UnicodeDecodeError, RecursionError, ValueError) as exc:   # ValueError: json.JSONDecodeError
        raise VolumeError(f"sidecar {path.name} is not valid JSON ({exc}); fix it or pass --dims "
                          f"--dtype on the command line") from None
    if not isinstance(keys, dict):
        raise VolumeError(f"sidecar {path.name} must hold a JSON object with keys {', '.join(SIDECAR_KEYS)}")
    unknown = sorted(set(keys) - set(SIDECAR_KEYS))
    if unknown:
        raise VolumeError(f"sidecar {path.name} has unknown key(s) {', '.join(unknown)}; "
                          f"allowed: {', '.join(SIDECAR_KEYS)}")
    return keys


def three_positive(values, flag: str, kind, where: str):
    """Three positive numbers from flags or a sidecar; `kind` int: whole numbers up to MAX_DIM (a
    product of dims is then taken with Python ints, which cannot wrap as int64 does)."""
    try:
        if isinstance(values, (str, bytes)) or any(isinstance(v, bool) for v in values):
            raise TypeError  # "123" is one number, not three; true is not a number, though int() takes it
        items = [kind(v) for v in values]
        whole = kind is not int or all(not isinstance(v, float) or v.is_integer() for v in values)
    except (TypeError, ValueError, OverflowError):  # not numbers; int(inf) overflows
        items, whole = [], False
    if len(items) != 3 or not whole or any(not 0 < v < math.inf for v in items) or (
            kind is int and any(v > MAX_DIM for v in items)):
        limit = f" up to {MAX_DIM}" if kind is int else ""
        raise VolumeError(f"{where}: {flag} needs three positive {'whole ' if kind is int else ''}"
                          f"numbers (X Y Z){limit}, got {_short(values)}")
    return tuple(items)


def _short(values) -> str:
    text = repr(values)
    return text if len(text) <= 80 else text[:77] + "..."


def raw_layout(path: Path, dims=None, dtype=None, endian=None, spacing=None) -> RawLayout:
    """Merge flags over the sidecar; flags win. dims is required from one of them."""
    notes: list[str] = []
    sidecar = sidecar_path(path)
    keys = _read_sidecar(sidecar) if sidecar else {}
    where = f"sidecar {sidecar.name}" if sidecar else "raw file"
    if sidecar:
        notes.append(f"layout from {sidecar.name}" + (" (flags override it)" if any(
            v is not None for v in (dims, dtype, endian, spacing)) else ""))
    dims = dims if dims is not None else keys.get("dims")
    if dims is None:
        raise VolumeError(f"{path.name} is raw data with no header: give --dims X Y Z (and --dtype), "
                          f"or write {path.name}.json with {{\"dims\": [X, Y, Z], \"dtype\": \"uint8\"}}")
    dims = three_positive(dims, "--dims", int, where)
    dtype_name = str(dtype if dtype is not None else keys.get("dtype", "uint8")).lower()
    if dtype_name not in RAW_DTYPES:
        raise VolumeError(f"unknown --dtype {dtype_name!r}; use one of {', '.join(RAW_DTYPES)}")
    endian_name = str(endian if endian is not None else keys.get("endian", "little")).lower()
    if endian_name not in ENDIANS:
        raise VolumeError(f"unknown --endian {endian_name!r}; use little or big")
    spacing = spacing if spacing is not None else keys.get("spacing")
    spacing = three_positive(spacing, "--spacing", float, where) if spacing is not None else None
    return RawLayout(dims, np.dtype(dtype_name).newbyteorder(ENDIANS[endian_name]), spacing, notes)


def _bytes(n: int) -> str:
    return f"{n} bytes" if n < 1 << 30 else f"{size_text(n)} ({n} bytes)"


def _check_file_size(path: Path, layout: RawLayout) -> None:
    n_voxels = math.prod(int(d) for d in layout.dims)  # Python ints: int64 would wrap
    expected = n_voxels * layout.dtype.itemsize
    actual = path.stat().st_size
    if actual == expected:
        return
    dims = " ".join(map(str, layout.dims))
    fitting = [name for name in RAW_DTYPES if n_voxels * np.dtype(name).itemsize == actual]
    hint = (f"try --dtype {' or '.join(fitting)}" if fitting else
            "check --dims and --dtype")
    if actual < expected:
        raise VolumeError(f"{path.name} is truncated or the layout is wrong: --dims {dims} as "
                          f"{layout.dtype.name} needs {_bytes(expected)}, the file has {actual} bytes; {hint}")
    raise VolumeError(f"{path.name} is larger than its layout: --dims {dims} as {layout.dtype.name} "
                      f"needs {expected} bytes, the file has {actual} ({actual - expected} extra, "
                      f"a header?); {hint}")


def load_raw(path: Path, dims=None, dtype=None, endian=None, spacing=None,
             progress: Progress | None = None, map_file: bool = False):
    """The array, axes transposed to x first: read whole when small, memory-mapped (read from disk a
    block at a time, so it may exceed RAM) from MAP_BYTES up, or at any size with `map_file` (dask
    workers then read the file by its name)."""
    layout = raw_layout(path, dims, dtype, endian, spacing)
    n_bytes = math.prod(int(d) for d in layout.dims) * layout.dtype.itemsize
    if path.stat().st_size < n_bytes:
        refuse_if_too_big(layout.dims, layout.dtype.itemsize, path.name)  # a header-less monster, or truncated
    _check_file_size(path, layout)
    x, y, z = layout.dims
    layout.notes.append(f"raw {shape_text(layout.dims)} {layout.dtype.name}")
    if n_bytes >= MAP_BYTES or map_file:
        mapped = np.memmap(path, dtype=layout.dtype, mode="r", shape=(z, y, x))
        return Block3D(mapped, reverse=True), layout.spacing, layout.notes
    file_order = np.empty((z, y, x), dtype=layout.dtype)
    buffer = file_order.reshape(-1).view(np.uint8)
    with open(path, "rb") as fp:
        done = 0
        while done < buffer.size:
            count = fp.readinto(memoryview(buffer[done:done + _READ_CHUNK]))
            if not count:
                raise VolumeError(f"{path.name} ended early while reading; is it still being written?")
            done += count
            report(progress, done / buffer.size,
                   f"reading {path.name} ({size_text(done)} of {size_text(buffer.size)})")
    return np.ascontiguousarray(file_order.transpose(2, 1, 0)), layout.spacing, layout.notes

