"""Checks on what users pass to the extractors: one-line ValueErrors that name the problem and the fix."""
from __future__ import annotations

import numpy as np

GRADIENT_DIRECTIONS = ("descent", "ascent")


def as_volume(volume) -> np.ndarray:
    """A C-contiguous float32 copy-if-needed of a finite 3-D array with every axis >= 2."""
    try:
        array = np.asarray(volume)
    except Exception as exc:  # ragged lists and the like
        raise ValueError(f"volume is not an array ({exc}); pass a 3-D numpy array") from None
    if array.dtype == object or not (np.issubdtype(array.dtype, np.number) or array.dtype == bool):
        raise ValueError(f"volume has dtype {array.dtype}; pass a numeric 3-D array")
    if np.iscomplexobj(array):
        raise ValueError("volume is complex; pass its real part or magnitude (np.abs)")
    if array.ndim != 3:
        raise ValueError(f"volume must be 3-D, got {array.ndim}-D with shape {array.shape}; "
                         "reshape it or pick one 3-D frame")
    if min(array.shape) < 2:
        raise ValueError(f"volume shape {array.shape} has an axis shorter than 2; "
                         "marching cubes needs at least 2 samples along every axis")
    field = np.ascontiguousarray(array, dtype=np.float32)
    finite = np.isfinite(field)
    if not finite.all():
        bad = np.argwhere(~finite)[0]
        count = int(field.size - np.count_nonzero(finite))
        raise ValueError(f"volume has {count} NaN or Inf samples (first at index {tuple(int(b) for b in bad)}); "
                         "replace them, e.g. np.nan_to_num(volume, nan=volume[np.isfinite(volume)].min())")
    if np.issubdtype(array.dtype, np.number) and array.dtype.itemsize > 4 and array.size:
        big = float(np.max(np.abs(array)))
        if big > np.finfo(np.float32).max:
            raise ValueError(f"volume values up to {big:g} overflow float32; rescale the data")
    return field


def as_spacing(spacing) -> tuple[float, float, float]:
    try:
        values = tuple(float(s) for s in spacing)
    except (TypeError, ValueError):
        raise ValueError(f"spacing {spacing!r} is not three numbers; pass e.g. (1.0, 1.0, 1.0)") from None
    if len(values) != 3:
        raise ValueError(f"spacing needs 3 values, one per axis, got {len(values)}")
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"spacing {values} must be finite and positive")
    return values


def as_gradient_direction(direction: str) -> bool:
    """True for "descent" (object above the level), False for "ascent"."""
    if direction not in GRADIENT_DIRECTIONS:
        raise ValueError(f"gradient_direction {direction!r} is not one of {GRADIENT_DIRECTIONS}")
    return direction == "descent"


def value_range(field: np.ndarray) -> tuple[float, float]:
    return float(field.min()), float(field.max())


def as_level(level, value_range: tuple[float, float]) -> float:
    """`None` -> the middle of the data range; a level outside the range is an error (as in scikit-image)."""
    lo, hi = value_range
    if level is None:
        return float(np.float32((lo + hi) / 2.0))
    try:
        value = float(level)
    except (TypeError, ValueError):
        raise ValueError(f"level {level!r} is not a number") from None
    if not np.isfinite(value):
        raise ValueError(f"level {value} is not finite")
    if not lo <= value <= hi:
        raise ValueError(f"level {value:g} is outside the data range [{lo:g}, {hi:g}]; pick a level inside it")
    return value
