"""Sampling a function of (x, y, z) on a regular grid over a box, slab by slab.

Shared by the built-in fields and the numpy expression evaluator so both put
sample (i, j, k) at exactly the same point:  lo + index * (hi - lo) / (n - 1).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .errors import VolumeError
from .volume import Progress, refuse_if_too_big, report

MIN_RESOLUTION = 2
MAX_RESOLUTION = 2048  # GL_MAX_3D_TEXTURE_SIZE on llvmpipe; bigger could never be drawn
LOWER_RESOLUTION = "use a lower resolution (e.g. --resolution 256)"
_SLAB_VOXELS = 1 << 22  # bounds the float64 temporaries numpy makes per slab


@dataclass(frozen=True)
class Box:
    """The box an implicit function is sampled over: its lower and upper corners."""
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    @classmethod
    def cube(cls, lo: float, hi: float) -> Box:
        """The cube from (`lo`, `lo`, `lo`) to (`hi`, `hi`, `hi`)."""
        return cls((lo, lo, lo), (hi, hi, hi))

    def spacing(self, shape) -> tuple[float, float, float]:
        """The sample spacing along each axis when `shape` samples span the box, its corners included."""
        return tuple((high - low) / (n - 1) for low, high, n in zip(self.lo, self.hi, shape))

    def axis(self, axis: int, n: int) -> np.ndarray:
        """The coordinates of the n samples along one axis, in float64."""
        return self.lo[axis] + np.arange(n, dtype=np.float64) * ((self.hi[axis] - self.lo[axis]) / (n - 1))


def check_resolution(resolution, what: str) -> int:
    """A samples-per-axis count from an int or from user text such as "64"."""
    text = str(resolution).strip()
    if isinstance(resolution, bool) or not text.isdigit():
        raise VolumeError(f"{what}: resolution {text!r} is not a whole number; give e.g. 64")
    n = int(text)
    if not MIN_RESOLUTION <= n <= MAX_RESOLUTION:
        raise VolumeError(f"{what}: resolution {n} is out of range; "
                          f"use {MIN_RESOLUTION}..{MAX_RESOLUTION} samples per axis")
    return n


def pick_resolution(in_spec, from_flag, default: int, what: str) -> int:
    """The resolution from the spec ("sphere:96", "res=96") or --resolution; both must agree."""
    if in_spec is not None and from_flag is not None and str(from_flag).strip() != str(in_spec).strip():
        raise VolumeError(f"{what}: resolution given twice ({in_spec} in the spec and --resolution "
                          f"{from_flag}); give it once")
    chosen = from_flag if from_flag is not None else in_spec
    return default if chosen is None else check_resolution(chosen, what)


def sample_function(fn: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray], box: Box,
                    shape: tuple[int, int, int], *, dtype=np.float32, what: str = "field",
                    progress: Progress | None = None) -> np.ndarray:
    """fn gets broadcastable coordinate arrays x (n0,1,1), y (1,n1,1), z (1,1,n2)."""
    refuse_if_too_big(shape, np.dtype(dtype).itemsize, what, fix=LOWER_RESOLUTION)
    out = np.empty(shape, dtype=dtype)
    y = box.axis(1, shape[1])[None, :, None]
    z = box.axis(2, shape[2])[None, None, :]
    x_all = box.axis(0, shape[0])
    step = max(1, _SLAB_VOXELS // (shape[1] * shape[2]))
    for start in range(0, shape[0], step):
        x = x_all[start:start + step, None, None]
        out[start:start + step] = np.broadcast_to(fn(x, y, z), (len(x), shape[1], shape[2]))
        report(progress, min(1.0, (start + step) / shape[0]), f"computing {what}")
    return out
