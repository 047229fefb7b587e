"""The Volume record and the checks every volume passes before anyone sees it.

Loaders and generators build the array; `finish_volume` is the single gate
that makes sure it is 3-D, numeric, finite and not constant, so the extractor
and the viewer can trust any Volume they are handed.
"""
from __future__ import annotations

import contextlib
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..core.budget import available_memory_bytes, size_text
from ..core.lazy_arrays import is_lazy
from ..errors import InputError
from ..validation import CheckedVolume, Progress, as_spacing, check_volume
from .errors import VolumeError

ANATOMICAL_SPACES = ("RAS", "LPS")
"""World frames that place the array in a patient (the viewer's anatomical camera, letters and view names);
any other (an OME-Zarr image's scale and translation) is a frame in the file's own units and axes."""


class PyramidLevel(NamedTuple):
    """A lower-resolution level of a volume: its lazy samples (same axes), their spacing, its name in the file
    (an OME-Zarr dataset's path), and where its sample 0 lies, in index units of the full level (along axes 0,
    1, 2): (0, 0, 0) for every f-th sample, (f - 1) / 2 for the means of f^3 blocks (their centres), as the
    file's translations say."""
    data: object
    spacing: tuple[float, float, float]
    name: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class Volume:
    """A 3-D scalar field ready to show: its samples, spacing, name, source, object side, first level, value range and
    notes, and, where the file gives them, its voxel-to-world transform and time points."""
    data: np.ndarray  # 3-D, native byte order, any memory order (a NIfTI's is Fortran); axis 0 is drawn as x;
    # real values (ints keep their range)
    spacing: tuple[float, float, float]  # voxel size along axes 0, 1, 2
    name: str  # short, for the window title / panel
    source: str  # the spec or path it came from
    gradient_direction: str  # "descent": object where values are above the level; "ascent": below
    default_level: float | None  # a good first iso value; None -> middle of the range
    value_range: tuple[float, float]  # (min, max) of the data, from finish_volume's one scan
    notes: list[str] = field(default_factory=list)  # things to tell the user
    # (4x4 array index (i, j, k, 1) -> world millimetres, "RAS" or "LPS") where the file defines
    # it (NIfTI, NRRD, DICOM); an OME-Zarr image's scale and translation: (diagonal with an offset, "OME-Zarr"),
    # its own units; None: world units are index x spacing.
    world: tuple[np.ndarray, str] | None = None
    _in_memory: np.ndarray | None = field(default=None, repr=False, compare=False)  # a lazy volume, once read
    # The options it was opened with (dims, dtype, endian, spacing, time, series, resolution; those
    # given), so another process can open the same volume (the viewer's full-resolution export).
    open_options: dict = field(default_factory=dict, compare=False)
    # How many 3-D volumes its source holds (a 4-D file's time points; 1 for the rest); open_options'
    # `time` says which one this is.
    time_points: int = 1
    # Lower-resolution copies of the same samples that came with it (an OME-Zarr image's multiscale levels),
    # finest first: what a viewer over its memory budget shows instead of striding through this one.
    pyramid: tuple[PyramidLevel, ...] = field(default=(), compare=False)
    # Where sample 0 sits in index x spacing units: (0, 0, 0) but for the viewer's coarse view of a pyramid
    # level whose samples lie off the full level's grid (big_volume.from_level: the level's offset times the
    # full spacing); its meshes, extracted at index x spacing, are placed (drawn, exported) this much further.
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # The length unit the file states for its spatial axes (core.units' name: "micrometer", "micron", ...), or
    # None where it states none (taken as millimetres); measures convert by it, exports keep the file's units.
    length_unit: str | None = None

    @property
    def checked(self) -> CheckedVolume:
        """The data as the extractors take it, already checked: they do not scan it again.

        A lazy volume (Zarr, a raw file's map) is read whole here: chunked.py reads it a box at a time."""
        if is_lazy(self.data):
            if self._in_memory is None:  # read once: the viewer asks for it again for each preview
                refuse_if_too_big(self.data.shape, self.data.dtype.itemsize, self.name,
                                  fix="export it a chunk at a time (isoscope export --chunk 128), or downsample it")
                data = np.asarray(self.data)
                self._in_memory = data.astype(data.dtype.newbyteorder("="), copy=False)
            return CheckedVolume(self._in_memory, self.value_range)
        return CheckedVolume(self.data, self.value_range)


def report(progress: Progress | None, fraction: float, message: str) -> None:
    """Tell `progress` (if any) the `fraction` done, clamped to 0..1, and what is being done."""
    if progress is not None:
        progress(min(max(float(fraction), 0.0), 1.0), message)


def shape_text(shape) -> str:
    """A shape as "256x256x128"."""
    return "x".join(str(int(n)) for n in shape)


# (whether one extraction takes a 3-D shape, the refusal's words) for the caller of an open that
# will take the volume in one piece: an export that is not chunked hands it to one extractor, so
# a header that implies more is refused before a byte of data is read, not after minutes of
# reading and gigabytes of memory.
_EXTRACTION_LIMIT: ContextVar[tuple[Callable[[tuple], bool], str] | None] = ContextVar("extraction_limit",
                                                                                        default=None)


@contextlib.contextmanager
def extraction_limit(fits: Callable[[tuple], bool] | None, refusal: str):
    """Within this block, refuse_if_too_big also refuses a whole 3-D volume whose shape `fits` rejects,
    saying "<what> is <shape> voxels (<n> samples), <refusal>"."""
    token = _EXTRACTION_LIMIT.set(None if fits is None else (fits, refusal))
    try:
        yield
    finally:
        _EXTRACTION_LIMIT.reset(token)


def refuse_if_too_big(shape, itemsize: int, what: str, *, copies: int = 1,
                      fix: str = "crop or downsample it first", whole_volume: bool = True) -> None:
    """Refuse, before allocating, a volume that cannot fit in memory (or, inside `extraction_limit`,
    a whole 3-D volume that the caller's one extraction cannot take; `whole_volume=False` for a
    piece of one, such as a Zarr chunk).

    The budget is half of what is available: the checks, a dtype conversion or
    the extractor's upload may need a second copy while the first is alive.
    `copies` counts the copies the caller itself holds at once. Sizes are Python
    integers: a header's dimensions cannot wrap around to a small product.
    """
    n_voxels = 1
    for n in shape:
        n_voxels *= int(n)
    limit = _EXTRACTION_LIMIT.get()
    if limit is not None and whole_volume and len(shape) == 3 and not limit[0](shape):
        raise VolumeError(f"{what} is {shape_text(shape)} voxels ({n_voxels:,} samples), {limit[1]}")
    n_bytes = n_voxels * int(itemsize) * copies
    budget = available_memory_bytes() // 2
    if n_bytes > budget:
        raise VolumeError(
            f"{what} is {shape_text(shape)} voxels ({size_text(n_bytes)} to load), more than this "
            f"machine can hold (about {size_text(budget)} usable): {fix}"
        )


def world_problem(matrix) -> str | None:
    """What makes a 4x4 index -> world matrix unusable (not finite, or its axes do not span space:
    a zeroed NIfTI sform, collinear NRRD space directions), or None when it is usable."""
    matrix = np.asarray(matrix, np.float64)
    if matrix.shape != (4, 4) or not np.all(np.isfinite(matrix)):
        return "is not finite"
    linear = matrix[:3, :3]
    lengths = np.linalg.norm(linear, axis=0)
    if np.any(lengths == 0):
        return f"gives array axis {int(np.argmin(lengths))} no length"
    if abs(np.linalg.det(linear / lengths)) < 1e-6:
        return "has array axes that point the same way (a singular matrix)"
    return None


def finish_volume(data: np.ndarray, *, spacing, name: str, source: str, gradient_direction: str,
                  default_level: float | None, notes: list[str] | None = None,
                  what: str | None = None, progress: Progress | None = None,
                  where: Callable[[tuple], str] | None = None,
                  world: tuple[np.ndarray, str] | None = None, length_unit: str | None = None) -> Volume:
    """The single gate: shape, dtype and value checks (validation.check_volume), then the record."""
    what = what or name
    try:
        checked = check_volume(data, what, progress=progress, where=where)
    except ValueError as exc:
        raise VolumeError(str(exc)) from None
    lo, hi = checked.value_range
    if lo == hi:
        raise VolumeError(
            f"{what} is constant (every sample is {lo:g}), so no level has a surface; "
            f"check the file, time point or formula"
        )
    try:
        spacing = as_spacing(spacing, checked.samples.shape)  # the one rule, as for the Python API's arrays
    except ValueError as exc:
        raise VolumeError(f"{what}: {exc}") from None
    notes = list(notes or [])
    if world is not None and (problem := world_problem(world[0])) is not None:
        notes.append(f"{what}: its header's index-to-world matrix {problem}; shown and exported in "
                     "index x spacing coordinates instead of world ones")
        world = None
    if gradient_direction not in ("descent", "ascent"):
        raise InputError(f"gradient_direction must be 'descent' or 'ascent', not {gradient_direction!r}")
    # The samples in their own memory order (no transpose of a Fortran-ordered file); native byte order.
    data = checked.samples if is_lazy(checked.samples) or checked.samples.dtype.isnative else checked.data
    return Volume(data=data, spacing=spacing, name=name, source=source,
                  gradient_direction=gradient_direction, default_level=default_level,
                  value_range=checked.value_range, notes=notes + list(checked.notes),
                  world=world, length_unit=length_unit)
