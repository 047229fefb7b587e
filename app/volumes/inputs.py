"""Volumes from what a Python user holds: a path, an array (numpy, a memory map, Zarr, dask), a nibabel
image, an xarray DataArray, or (array, affine) -- the door `isoscope.render`, `isosurface` and `view` take.

World coordinates come with the input where it has them: a nibabel image's affine (RAS millimetres), an
`affine=` given (4x4, array index -> world), or an xarray DataArray's coordinates (uniform steps: spacing,
their first values: origin).  Everything passes the same gate as a file (`finish_volume`): 3-D, numeric,
finite, not constant; a lazy array (Zarr, dask, a memory map) stays lazy until it is extracted.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import VolumeError
from .volume import Volume, finish_volume


def as_volume(obj, *, spacing=None, affine=None, gradient_direction: str = "descent", name: str | None = None,
              **open_options) -> Volume:
    """A Volume of `obj` (see the module docstring); `spacing` overrides the input's own, `affine` gives
    its index -> world matrix (RAS).  A path or spec is opened as the command opens it (`open_options`:
    time, series, dims, ...).  Bad input raises VolumeError with its one line."""
    if isinstance(obj, Volume):
        return obj
    if isinstance(obj, (str, Path)):
        from . import open_volume
        return open_volume(str(obj), spacing=spacing, **open_options)
    if open_options:
        raise VolumeError(f"{', '.join(sorted(open_options))} only apply to files; drop them for an array")
    world = None
    if isinstance(obj, tuple) and len(obj) == 2 and np.ndim(obj[1]) == 2:   # (array, affine)
        obj, affine = obj
    length_unit, spacing_given = None, spacing   # a spacing given is taken as mm, as --spacing is (loaders.py)
    if _is_nibabel_image(obj):
        affine = obj.affine if affine is None else affine
        name = name or "nibabel image"
        length_unit = _nibabel_unit(obj)   # as open_volume reads the file's (nifti_format.nifti_unit)
        obj = np.asanyarray(obj.dataobj)
    elif _is_xarray(obj):
        obj, steps, origin = _xarray_grid(obj)
        if affine is None:   # a descending coordinate is a mirrored axis
            affine = np.diag([*steps, 1.0])
            affine[:3, 3] = origin
        name = name or "DataArray"
    if affine is not None:
        affine = np.asarray(affine, np.float64)
        if affine.shape != (4, 4) or not np.all(np.isfinite(affine)):
            raise VolumeError(f"affine must be a finite 4x4 matrix (array index -> world), not shape "
                              f"{affine.shape}")
        if spacing is None:
            spacing = tuple(float(s) for s in np.linalg.norm(affine[:3, :3], axis=0))
        world = (affine, "RAS")
    try:
        data = obj if _keeps_lazy(obj) else np.asarray(obj)
    except (ValueError, TypeError) as exc:
        raise VolumeError(f"a {type(obj).__name__} is not an array of numbers ({exc}); pass a 3-D numeric "
                          "array, a path, a nibabel image or an xarray DataArray") from None
    return finish_volume(data, spacing=spacing or (1.0, 1.0, 1.0), name=name or type(obj).__name__,
                         source=name or "array", gradient_direction=gradient_direction, default_level=None,
                         world=world, length_unit=length_unit if spacing_given is None else None)


def _nibabel_unit(image) -> str | None:
    """The spatial unit a nibabel image's header states (None: none, or a header without xyzt units)."""
    from ..core.units import length_unit_name
    try:
        return length_unit_name(image.header.get_xyzt_units()[0])
    except (AttributeError, KeyError, ValueError, IndexError):
        return None


def _is_nibabel_image(obj) -> bool:
    return hasattr(obj, "affine") and hasattr(obj, "dataobj") and hasattr(obj, "header")


def _is_xarray(obj) -> bool:
    return type(obj).__module__.startswith("xarray") and hasattr(obj, "coords") and hasattr(obj, "dims")


def _xarray_grid(array):
    """(values, steps, origin) of a 3-D DataArray: uniform coordinates give the step and first value."""
    if array.ndim != 3:
        raise VolumeError(f"the DataArray has {array.ndim} dimensions {tuple(array.dims)}; isoscope needs 3")
    steps, origin = [], []
    for dim, n in zip(array.dims, array.shape):
        coord = np.asarray(array.coords[dim].values, np.float64) if dim in array.coords else None
        if coord is None or n < 2:
            steps.append(1.0)
            origin.append(0.0 if coord is None else float(coord[0]))
            continue
        step = np.diff(coord)
        if not np.allclose(step, step[0], rtol=1e-6, atol=0) or step[0] == 0:
            raise VolumeError(f"the DataArray's {dim!r} coordinates are not evenly spaced; resample it to a "
                              "regular grid first")
        steps.append(float(step[0]))
        origin.append(float(coord[0]))
    return array.data, steps, origin


def _keeps_lazy(obj) -> bool:
    """Zarr arrays and memory maps are read a block at a time where the extraction allows; dask arrays too."""
    from ..core.lazy_arrays import is_lazy
    return isinstance(obj, np.memmap) or (is_lazy(obj) and getattr(obj, "ndim", 0) == 3)
