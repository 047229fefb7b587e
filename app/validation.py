"""Checks on what users pass to the extractors: one-line ValueErrors that name the problem and the fix."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .core.layout import IN_PLACE_DTYPES
from .core.lazy_arrays import is_lazy, maps_a_file, release_pages
from .errors import InputError

GRADIENT_DIRECTIONS = ("descent", "ascent")


Progress = Callable[[float, str], None]

# Checking finiteness and range in slabs keeps the temporary bool arrays small (a full-size
# finiteness mask is a byte per voxel) and gives a progress callback something to report.
CHECK_SLAB_BYTES = 64 << 20
FLOAT32_MAX = float(np.finfo(np.float32).max)


@dataclass(frozen=True)
class CheckedVolume:
    """An array that passed `check_volume`, with the value range that same scan found.

    `samples` is the array as the user gave it: 3-D, numeric (float16 and bool widened), finite, at
    least 2 long on every axis, and within float32's range, in any memory order and byte order (nibabel
    gives Fortran order; a slice may have negative strides; some files are big-endian); its dtype is
    otherwise kept (integers stay integers).  The compiled CPU kernels read it in place
    (`isoscope.cpu.samples`).  `data` is the same samples C-contiguous in native byte order, made on first
    use (the array itself where it is so already), for the code that needs that layout (the GPU upload,
    numpy's reference).  The extractors take one as it is, without scanning again.
    A lazy array (Zarr: see lazy_arrays) is checked block by block and kept lazy; chunked.py reads it.

    `value_range` is None for a volume made by `check_volume(..., scan_values=False)`: its shape
    and type passed, its values are not scanned yet.  Only an `Extractor` takes such a volume:
    its upload pass scans them (measuring the brick ranges it needs anyway), and it raises
    check_volume's own error for a non-finite sample.
    """
    samples: np.ndarray
    value_range: tuple[float, float] | None
    notes: tuple[str, ...] = ()

    @cached_property
    def data(self) -> np.ndarray:
        """The samples C-contiguous in native byte order (a copy only where they are not)."""
        return c_ordered(self.samples)


def c_ordered(data):
    """`data` C-contiguous in native byte order: itself where it is, a copy where it is not; a lazy array as it is."""
    if is_lazy(data):
        return data
    if not data.dtype.isnative:
        data = data.astype(data.dtype.newbyteorder("="), order="C")
    return np.ascontiguousarray(data)


def subsampled(checked: CheckedVolume, step: int) -> CheckedVolume:
    """Every `step`-th sample along each axis (scikit-image's step_size).  Its value range is the
    full volume's, a bound on the samples kept, so every level of the full volume stays valid."""
    data = checked.samples[::step, ::step, ::step]   # a view: the kernels read it in place, strides and all
    if min(data.shape) < 2:
        raise InputError(f"step_size {step} leaves the volume {'x'.join(map(str, checked.samples.shape))} "
                         f"with an axis shorter than 2 samples; use a smaller step_size")
    return CheckedVolume(data, checked.value_range, checked.notes)


def as_step_size(step_size) -> int:
    """`step_size` as an int, if it is a whole number of voxels, 1 or more; else an InputError."""
    if isinstance(step_size, bool) or not isinstance(step_size, (int, np.integer)) or step_size < 1:
        raise InputError(f"step_size must be a whole number of voxels, 1 or more; got {step_size!r}")
    return int(step_size)


def _at_index(index) -> str:
    return f"at index {tuple(int(i) for i in index)}; replace them (e.g. np.nan_to_num) first"


GPU_SCANNED_DTYPES = ("float32", "uint8", "int8", "uint16", "int16")
"""Sample types the GPU holds exactly (layout.VOLUME_TEXEL_FORMATS), so that its scan of the
values finds the same range as numpy's."""
CPU_SCANNED_DTYPES = IN_PLACE_DTYPES
"""Sample types whose values the compiled CPU extractor measures in its first pass (`isoscope.cpu.compiled`,
reading them in their own type), so that they need no scan of their own."""


def check_volume(volume, what: str = "volume", *, progress: Progress | None = None,
                 where: Callable[[tuple], str] | None = None, scan_values: bool = True,
                 deferred: tuple[str, ...] = GPU_SCANNED_DTYPES) -> CheckedVolume:
    """The one check every volume passes, from a user's array or a file: shape, dtype, values.

    Values are scanned once: an array in memory by numpy in its memory order, a memory map or a lazy
    array a slab at a time.  `what` names the volume in messages; `where` words the first bad sample's
    place and the fix.  scan_values=False leaves the values of an in-memory array of a `deferred` type
    to the extractor that reads them anyway (value_range None): the GPU upload (GPU_SCANNED_DTYPES, 9 ms
    of a 256^3 float32 one-shot call) or the compiled CPU extractor's first pass (CPU_SCANNED_DTYPES).
    """
    if isinstance(volume, CheckedVolume):
        if volume.value_range is not None or not scan_values:
            return volume
        volume = volume.samples  # its values were left to an upload: scan them here after all
    where = where or _at_index
    data, notes = _numeric_3d(volume, what)
    if not scan_values and not is_lazy(data) and str(data.dtype.newbyteorder("=")) in deferred:
        return CheckedVolume(data, None, tuple(notes))
    lo, hi = _in_memory_range(data)
    if lo is not None:
        return CheckedVolume(data, _within_float32(lo, hi, what), tuple(notes))
    lo, hi = np.inf, -np.inf
    pieces = list(blocks(data.shape, data.dtype.itemsize))
    for number, block in enumerate(pieces, 1):
        slab = np.asarray(data[block])
        release_pages(data)  # a memory-mapped file: keep only one slab resident
        slab_lo, slab_hi = float(slab.min()), float(slab.max())
        # min and max carry any NaN and +-Inf through, so only a slab whose range is not finite
        # needs the (4x slower) finiteness mask, to find the first bad sample and count them.
        if data.dtype.kind == "f" and not (np.isfinite(slab_lo) and np.isfinite(slab_hi)):
            bad = ~np.isfinite(slab)
            if bad.any():
                index = tuple(int(i) + part.start for i, part in
                              zip(np.unravel_index(int(np.argmax(bad)), slab.shape), block))
                count = sum(int(np.count_nonzero(~np.isfinite(np.asarray(data[b])))) for b in pieces)
                raise InputError(f"{what} has {count} NaN/Inf sample(s), the first ({data[index]}) "
                                 f"{where(index)}")
        lo, hi = min(lo, slab_lo), max(hi, slab_hi)
        if len(pieces) > 1 and progress is not None:
            progress(number / len(pieces), f"checking {what}")
    return CheckedVolume(data, _within_float32(lo, hi, what), tuple(notes))


def _in_memory_range(data) -> tuple[float | None, float | None]:
    """The smallest and largest sample of an array in memory, each one pass of numpy's over the samples in
    their memory order (a 512x512x400 int16 CT: 15 ms for both, a Fortran-ordered one too, against 140 ms
    in slabs of planes across its memory); (None, None) where the slab scan must run instead: a memory map
    (its pages are dropped slab by slab), a lazy array, or a NaN or infinite sample (the slabs find the
    first and count them, for the message)."""
    if is_lazy(data) or maps_a_file(data):
        return None, None
    lo, hi = data.min(), data.max()
    if data.dtype.kind == "f" and not (np.isfinite(lo) and np.isfinite(hi)):
        return None, None
    return float(lo), float(hi)


def accept_measured(checked: CheckedVolume, value_range: tuple[float, float] | None, level,
                    what: str = "volume") -> tuple[float, float]:
    """The value range an extractor measured of `checked` (left unscanned), held to check_volume's rules and
    `level` to it (as_level): raises check_volume's own error where a sample is NaN or infinite (None)."""
    if value_range is None:
        check_volume(checked.samples, what)  # raises, naming the first bad sample
        raise AssertionError("a non-finite sample the scan did not find")
    value_range = _within_float32(*value_range, what)
    as_level(level, value_range)
    return value_range


def _within_float32(lo: float, hi: float, what: str) -> tuple[float, float]:
    if max(-lo, hi) > FLOAT32_MAX:
        raise InputError(f"{what} has values up to {max(-lo, hi):g}, beyond float32's range "
                         f"(+-{FLOAT32_MAX:.3g}) that the GPU computes in; rescale the data")
    return lo, hi


def blocks(shape, itemsize: int):
    """Slices covering a 3-D array in C order, each of at most CHECK_SLAB_BYTES where a row allows:
    slabs of axis-0 planes, a plane split along axis 1 when one is bigger (a lazy 10^5 x 10^5
    plane would be 37 GiB read at once), a row along axis 2 when even that is."""
    n0, n1, n2 = (int(n) for n in shape)
    row = n2 * itemsize
    if n1 * row <= CHECK_SLAB_BYTES:
        step = max(1, CHECK_SLAB_BYTES // max(1, n1 * row))
        for i in range(0, n0, step):
            yield slice(i, min(i + step, n0)), slice(0, n1), slice(0, n2)
        return
    rows = max(1, CHECK_SLAB_BYTES // max(1, row))
    columns = n2 if row <= CHECK_SLAB_BYTES else max(1, CHECK_SLAB_BYTES // itemsize)
    for i in range(n0):
        for j in range(0, n1, rows):
            for k in range(0, n2, columns):
                yield slice(i, i + 1), slice(j, min(j + rows, n1)), slice(k, min(k + columns, n2))


def _numeric_3d(volume, what: str) -> tuple[np.ndarray, list[str]]:
    """A numeric 3-D view of `volume` in its own memory order and byte order (a copy only for bool and
    float16), and notes on what changed."""
    if is_lazy(volume) and volume.dtype.kind in "iuf" and volume.dtype != np.float16 and len(volume.shape) == 3 \
            and min(volume.shape) >= 2:
        return volume, []  # read on demand, a block at a time; never as a whole
    try:
        data = np.asarray(volume)
    except Exception as exc:  # ragged lists and the like
        raise InputError(f"{what} is not an array ({exc}); pass a 3-D numpy array") from None
    notes: list[str] = []
    if data.dtype == np.bool_:
        data = data.astype(np.uint8)
        notes.append("boolean array shown as 0/1")
    elif data.dtype.kind == "c":
        raise InputError(f"{what} holds complex numbers ({data.dtype}); use its magnitude or real "
                         "part (np.abs(a) or a.real)")
    elif data.dtype.kind not in "iuf":
        raise InputError(f"{what} holds {data.dtype} values, not numbers (dtype {data.dtype}); "
                         "convert it to numbers (e.g. a.astype(np.float32))")
    if data.dtype == np.float16:
        data = data.astype(np.float32)
    if data.ndim != 3:
        hint = "stack the slices into one 3-D array (np.stack)" if data.ndim < 3 else "pick one 3-D volume from it"
        shape = "x".join(str(n) for n in data.shape) or "scalar"
        raise InputError(f"{what} is a {data.ndim}-D array (shape {shape}); isoscope needs a 3-D array: {hint}")
    if min(data.shape) < 2:
        raise InputError(f"{what} has shape {'x'.join(str(n) for n in data.shape)}, an axis shorter than 2; "
                         "every axis needs at least 2 samples to hold a surface")
    return data, notes


MIN_SPACING = 2.0 ** -60  # 8.7e-19
MAX_SPACING = 2.0 ** 60   # 1.2e18
"""The voxel sizes a mesh survives in float32, whatever the volume's shape (up to 2^31 samples per axis).
Vertices are index x spacing: under 2^91, finite in float32 (1e300 made inf vertices), and spacing is a
normal float32 far above its smallest (2^-126) with 23 bits to tell neighbours and in-cell positions apart
(1e-300 is 0 in float32: every vertex one point).  Normals are a gradient divided by the spacing, whose
square must stay inside float32's normal range too: (2^60)^2 = 2^120 < 2^128.  Checked at 1e-19 and 1e18:
the mesh is the spacing-1 mesh scaled, normals of unit length to 1e-7; at 1e-30 and 1e20 they are not."""


def as_spacing(spacing, shape=None) -> tuple[float, float, float]:
    """Three voxel sizes, each finite, positive and within MIN_SPACING..MAX_SPACING; with `shape`, the
    volume's extent spacing x (n - 1) must be finite in float32 too.  The one rule on spacing: the Python
    API (marching_cubes, Extractor, label_surfaces) and the command line (--spacing, a header's) both
    come here."""
    try:
        values = tuple(float(s) for s in spacing)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"spacing {spacing!r} is not three numbers; pass e.g. (1.0, 1.0, 1.0)") from None
    if len(values) != 3:
        raise InputError(f"spacing needs 3 values, one per axis, got {len(values)}")
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise InputError(f"spacing {_numbers(values)} must be finite and positive")
    if not all(MIN_SPACING <= v <= MAX_SPACING for v in values):
        raise InputError(f"spacing {_numbers(values)} is out of range: each voxel size must lie within "
                         f"{MIN_SPACING:.2g} .. {MAX_SPACING:.2g}, or the mesh's float32 vertices and normals "
                         f"overflow or collapse to a point; give it in other units (e.g. mm instead of m)")
    if shape is not None:
        extent = max(v * (int(n) - 1) for v, n in zip(values, shape))
        if not extent <= FLOAT32_MAX:
            raise InputError(f"spacing {_numbers(values)} over {'x'.join(map(str, shape))} samples spans "
                             f"{extent:.3g}, beyond float32's range; give the spacing in other units")
    return values


def _numbers(values) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"


def as_gradient_direction(direction: str) -> bool:
    """True for "descent" (object above the level), False for "ascent"."""
    if direction not in GRADIENT_DIRECTIONS:
        raise InputError(f"gradient_direction {direction!r} is not one of {GRADIENT_DIRECTIONS}")
    return direction == "descent"


def named_level(level, value_range: tuple[float, float], name: str) -> float:
    """`level` as a float inside `value_range` of the volume called `name`, else a ValueError in the command
    line's words (`--iso`): "level 5 is outside NAME's value range lo .. hi; pick a value inside it".  The
    doors that take a volume (view, render, widget, isosurface) say it so; marching_cubes keeps as_level's."""
    try:
        value = float(level)
    except (TypeError, ValueError):
        raise InputError(f"level {level!r} is not a number; give the iso value as a float") from None
    low, high = value_range
    if not low <= value <= high:   # NaN too
        raise InputError(f"level {value:g} is outside {name}'s value range {low:g} .. {high:g}; "
                         "pick a value inside it")
    return value


def as_level(level, value_range: tuple[float, float]) -> float:
    """`None` -> the middle of the data range; a level outside the range is an error (as in scikit-image)."""
    lo, hi = value_range
    if level is None:
        return float(np.float32((lo + hi) / 2.0))
    try:
        value = float(level)
    except (TypeError, ValueError):
        raise InputError(f"level {level!r} is not a number") from None
    if not np.isfinite(value):
        raise InputError(f"level {value} is not finite")
    if not lo <= value <= hi:
        raise InputError(f"level {value:g} is outside the data range [{lo:g}, {hi:g}]; pick a level inside it")
    return value
