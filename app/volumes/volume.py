"""The Volume record and the checks every volume passes before anyone sees it.

Loaders and generators build the array; `finish_volume` is the single gate
that makes sure it is 3-D, numeric, finite and not constant, so the extractor
and the viewer can trust any Volume they are handed.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from .errors import VolumeError

Progress = Callable[[float, str], None]

# Checking finiteness and range in slabs keeps the temporary bool arrays small
# and gives the progress callback something to report on big volumes.
_CHECK_SLAB_BYTES = 64 << 20


@dataclass
class Volume:
    data: np.ndarray  # 3-D, C-order, axis 0 is drawn as x; real values (ints keep their range)
    spacing: tuple[float, float, float]  # voxel size along axes 0, 1, 2
    name: str  # short, for the window title / panel
    source: str  # the spec or path it came from
    gradient_direction: str  # "descent": object where values are above the level; "ascent": below
    default_level: float | None  # a good first iso value; None -> middle of the range
    notes: list[str] = field(default_factory=list)  # things to tell the user

    @cached_property
    def value_range(self) -> tuple[float, float]:
        """(min, max) of the data; finish_volume fills it from its own scan."""
        return float(self.data.min()), float(self.data.max())


def report(progress: Progress | None, fraction: float, message: str) -> None:
    if progress is not None:
        progress(min(max(float(fraction), 0.0), 1.0), message)


def shape_text(shape) -> str:
    return "x".join(str(int(n)) for n in shape)


def size_text(n_bytes: float) -> str:
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB")
    step = 0
    while n_bytes >= 1024 and step < len(units) - 1:
        n_bytes, step = n_bytes / 1024, step + 1
    return f"{n_bytes:.1f} {units[step]}" if step else f"{int(n_bytes)} B"


def available_memory_bytes() -> int:
    """What this process may still allocate: MemAvailable on Linux, physical memory elsewhere."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 34


def refuse_if_too_big(shape, itemsize: int, what: str, *, copies: int = 1,
                      fix: str = "crop or downsample it first") -> None:
    """Refuse, before allocating, a volume that cannot fit in memory.

    The budget is half of what is available: the checks, a dtype conversion or
    the extractor's upload may need a second copy while the first is alive.
    `copies` counts the copies the caller itself holds at once.
    """
    n_voxels = 1
    for n in shape:
        n_voxels *= int(n)
    n_bytes = n_voxels * int(itemsize) * copies
    budget = available_memory_bytes() // 2
    if n_bytes > budget:
        raise VolumeError(
            f"{what} is {shape_text(shape)} voxels ({size_text(n_bytes)} to load), more than this "
            f"machine can hold (about {size_text(budget)} usable): {fix}"
        )


def as_numeric_3d(data: np.ndarray, what: str) -> tuple[np.ndarray, list[str]]:
    """Check dtype and dimensionality; return a C-ordered array and any notes."""
    notes: list[str] = []
    if data.dtype == np.bool_:
        data = data.astype(np.uint8)
        notes.append("boolean array shown as 0/1")
    elif data.dtype.kind in "c":
        raise VolumeError(
            f"{what} holds complex numbers ({data.dtype}); save np.abs(a) or a.real instead"
        )
    elif data.dtype.kind not in "iuf":
        raise VolumeError(
            f"{what} holds {data.dtype} values, not numbers; save a numeric array "
            f"(e.g. a.astype(np.float32))"
        )
    if data.dtype == np.float16:
        data = data.astype(np.float32)
    if data.ndim != 3:
        hint = "stack the slices into one 3-D array (np.stack)" if data.ndim < 3 else (
            "pick one 3-D volume from it")
        raise VolumeError(
            f"{what} is a {data.ndim}-D array (shape {shape_text(data.shape) or 'scalar'}); "
            f"isoscope needs a 3-D array: {hint}"
        )
    if min(data.shape) < 2:
        raise VolumeError(
            f"{what} has shape {shape_text(data.shape)}; every axis needs at least 2 samples "
            f"to hold a surface"
        )
    if not data.dtype.isnative:
        data = data.astype(data.dtype.newbyteorder("="))
    return np.ascontiguousarray(data), notes


def _at_index(index) -> str:
    return f"at index {tuple(int(i) for i in index)}; replace them (e.g. np.nan_to_num) before loading"


def check_values(data: np.ndarray, what: str, progress: Progress | None = None,
                 where: Callable[[tuple], str] = _at_index) -> tuple[float, float]:
    """The value range; refuses NaN/Inf samples and constant volumes.

    `where` words the first bad sample's place and the fix.
    """
    plane_bytes = max(1, data[0].nbytes)
    step = max(1, _CHECK_SLAB_BYTES // plane_bytes)
    lo, hi = np.inf, -np.inf
    for start in range(0, data.shape[0], step):
        slab = data[start:start + step]
        if data.dtype.kind == "f":
            bad = ~np.isfinite(slab)
            if bad.any():
                index = np.unravel_index(int(np.argmax(bad)), slab.shape)
                index = (index[0] + start,) + tuple(index[1:])
                count = int(np.count_nonzero(~np.isfinite(data)))
                raise VolumeError(f"{what} has {count} NaN/Inf sample(s), the first ({data[index]}) "
                                  f"{where(index)}")
        lo = min(lo, float(slab.min()))
        hi = max(hi, float(slab.max()))
        if data.shape[0] > step:
            report(progress, (start + step) / data.shape[0], f"checking {what}")
    if lo == hi:
        raise VolumeError(
            f"{what} is constant (every sample is {lo:g}), so no level has a surface; "
            f"check the file, frame or formula"
        )
    return lo, hi


def finish_volume(data: np.ndarray, *, spacing, name: str, source: str, gradient_direction: str,
                  default_level: float | None, notes: list[str] | None = None,
                  what: str | None = None, progress: Progress | None = None,
                  where: Callable[[tuple], str] = _at_index) -> Volume:
    """The single gate: shape, dtype and value checks, then the record."""
    what = what or name
    data, dtype_notes = as_numeric_3d(np.asarray(data), what)
    value_range = check_values(data, what, progress, where)
    spacing = tuple(float(s) for s in spacing)
    if len(spacing) != 3 or not all(np.isfinite(s) and s > 0 for s in spacing):
        raise VolumeError(f"{what}: spacing {spacing} must be three positive numbers")
    if gradient_direction not in ("descent", "ascent"):
        raise ValueError(f"gradient_direction must be 'descent' or 'ascent', not {gradient_direction!r}")
    volume = Volume(data=data, spacing=spacing, name=name, source=source,
                    gradient_direction=gradient_direction, default_level=default_level,
                    notes=list(notes or []) + dtype_notes)
    volume.__dict__["value_range"] = value_range  # already scanned: spare callers another pass
    return volume
