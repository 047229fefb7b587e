"""`marching_cubes`: scikit-image's call, on the GPU or in numpy."""
from __future__ import annotations

import numpy as np

from . import validation
from .reference import marching_cubes_reference

BACKENDS = ("auto", "gpu", "cpu")
METHODS = ("lewiner", "lorensen")


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", backend="auto", chunks=None):
    """Extract the isosurface ``volume == level`` as an indexed, watertight triangle mesh.

    Parameters follow ``skimage.measure.marching_cubes``:

    volume : 3-D array, every axis at least 2 long, finite values (or a
        `validation.CheckedVolume`, which is not scanned again).
    level : float, default the middle of the data range; must lie within it.
    spacing : voxel size along axes 0, 1, 2; vertices are scaled by it.
    gradient_direction : "descent" when the object is where values are above
        the level (densities, CT), "ascent" when below (signed distances).
        Normals point out of the object and triangles wind counter-clockwise
        seen from outside.
    step_size : sample every step_size-th grid point along each axis (a coarser,
        faster mesh in the same units); 1 is every sample.
    allow_degenerate : accepted for scikit-image's sake; this mesh never has
        degenerate (zero-area) triangles, so either value gives the same mesh.
    method : "lewiner" or "lorensen", accepted for scikit-image's sake; both give
        this extractor's mesh, whose case table resolves ambiguous faces from their
        four corners (Montani et al. 1994), so it is watertight as "lewiner" is, and
        unlike "lorensen" never has holes.
    backend : "gpu" (OpenGL 4.3 compute shaders; a standalone EGL context when
        none is current), "cpu" (the numpy reference), or "auto" (GPU when an
        OpenGL 4.3 context can be had).
    chunks : None (the whole volume at once), or N or (a, b, c): extract boxes of at most
        that many cells per axis on the GPU, one at a time, and stitch them by global
        edge id into the same mesh (see isoscope.chunked).  Memory then grows with the box,
        not the volume: use it for volumes larger than the GPU or RAM (a memory-mapped
        array, np.load(path, mmap_mode="r"), or a Zarr array is read a box at a time).

    Returns ``verts`` (N, 3) float32 in array-index order times spacing,
    ``faces`` (M, 3) int32, ``normals`` (N, 3) float32 unit vectors, ``values``
    (N,) float32.  Every grid edge whose ends lie on different sides of the
    level has exactly one vertex, shared by the triangles that use it.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r} is not one of {BACKENDS}")
    if method not in METHODS:
        raise ValueError(f"method {method!r} is not one of {METHODS}")
    if chunks is not None:
        return _chunked(volume, level, spacing, gradient_direction, step_size, backend, chunks)
    checked = validation.check_volume(volume)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    level = validation.as_level(level, checked.value_range)
    step = validation.as_step_size(step_size)
    if step > 1:
        checked = validation.subsampled(checked, step)
        spacing = tuple(s * step for s in spacing)

    if backend == "auto":
        from .gl_context import gl_available
        backend = "gpu" if gl_available() else "cpu"
    if backend == "cpu":
        return marching_cubes_reference(checked.data.astype(np.float32, copy=False), level, spacing, descent)

    from .extractor import Extractor
    extractor = Extractor(checked, spacing=spacing, gradient_direction=gradient_direction)
    try:
        extractor.extract(level)
        return extractor.read_mesh()
    finally:
        extractor.release()


def _chunked(volume, level, spacing, gradient_direction, step_size, backend, chunks):
    from .chunked import as_chunks, marching_cubes_chunked, value_range
    from .lazy_arrays import is_lazy
    if backend == "cpu" or step_size != 1:
        raise ValueError("chunks= runs on the GPU at step_size 1; drop chunks, or use backend='gpu' and step_size=1")
    source = volume.data if isinstance(volume, validation.CheckedVolume) else volume
    if not is_lazy(source):
        source = validation._numeric_3d(source, "volume")[0]  # shape and dtype only: no scan of the values
    as_chunks(chunks, source.shape)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    known = volume.value_range if isinstance(volume, validation.CheckedVolume) else None
    if known is None and level is not None:
        known = (-np.inf, np.inf)  # not scanned for a range: boxes the level misses give no surface
    level = validation.as_level(level, known or value_range(source, chunks))
    return marching_cubes_chunked(source, level, spacing, descent, chunks)
