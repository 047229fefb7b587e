"""`marching_cubes` (scikit-image's call) and `marching_tetrahedra`, on the GPU or in numpy."""
from __future__ import annotations

import numpy as np

from . import validation
from .reference import marching_cubes_reference
from .reference_tetra import marching_tetrahedra_reference

BACKENDS = ("auto", "gpu", "cpu")
METHODS = ("lewiner", "lorensen")


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", backend="auto"):
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

    Returns ``verts`` (N, 3) float32 in array-index order times spacing,
    ``faces`` (M, 3) int32, ``normals`` (N, 3) float32 unit vectors, ``values``
    (N,) float32.  Every grid edge whose ends lie on different sides of the
    level has exactly one vertex, shared by the triangles that use it.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r} is not one of {BACKENDS}")
    if method not in METHODS:
        raise ValueError(f"method {method!r} is not one of {METHODS}")
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


TETRA_BACKENDS = ("auto", "gpu", "cpu", "numpy")


def marching_tetrahedra(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                        backend="auto", smooth=0):
    """Extract the isosurface ``volume == level`` by marching tetrahedra (Müller and Wehle).

    Every cell is split into six tetrahedra along its main diagonal, the same way in every
    cell, so they meet face to face across cells (see `isoscope.reference_tetra`).  Inside a
    tetrahedron the field is linear, so no cell is ambiguous: the surface is the level set
    of the piecewise-linear interpolant, watertight and 2-manifold by construction, at the
    price of about three times marching cubes' triangles and vertices.

    Arguments, returns and conventions are `marching_cubes`'s (ties count as inside,
    normals point out of the object, triangles wind counter-clockwise seen from outside).
    Every edge of the tetrahedral grid (the three axes, the three face diagonals and the
    body diagonal of each cell) whose ends lie on different sides of the level has exactly
    one vertex.  backend: "gpu", "cpu" (or "numpy": the numpy reference), or "auto".
    smooth: smoothing iterations; only 0 (none) for now.
    """
    if backend not in TETRA_BACKENDS:
        raise ValueError(f"backend {backend!r} is not one of {TETRA_BACKENDS}")
    if isinstance(smooth, bool) or not isinstance(smooth, (int, np.integer)) or smooth < 0:
        raise ValueError(f"smooth must be a whole number of iterations, 0 or more; got {smooth!r}")
    if smooth:  # the hook for smoothing projected onto the level set (issue 9), once it exists
        raise ValueError(f"smooth={smooth} is not available for marching_tetrahedra yet; pass smooth=0")
    checked = validation.check_volume(volume)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    level = validation.as_level(level, checked.value_range)

    if backend == "auto":
        from .gl_context import gl_available
        backend = "gpu" if gl_available() else "cpu"
    if backend in ("cpu", "numpy"):
        return marching_tetrahedra_reference(checked.data.astype(np.float32, copy=False), level, spacing, descent)

    from .extractor import Extractor
    from .tetra_extractor import TetraExtractor
    with Extractor(checked, spacing=spacing, gradient_direction=gradient_direction) as cubes:
        tetra = TetraExtractor(cubes)
        try:
            tetra.extract(level)
            return tetra.read_mesh()
        finally:
            tetra.release()
