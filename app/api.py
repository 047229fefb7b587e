"""`marching_cubes`: scikit-image's call, on the GPU or in numpy."""
from __future__ import annotations

import numpy as np

from . import validation
from .reference import marching_cubes_reference
from .reference_sharp import check_feature_angle, sharpen_extracted

BACKENDS = ("auto", "gpu", "cpu")
METHODS = ("lewiner", "lorensen")


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", backend="auto",
                   sharp_features=None):
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

    sharp_features : None for plain marching cubes, or a feature angle in degrees
        (0 < angle < 180, e.g. 30): Extended Marching Cubes (Kobbelt et al. 2001,
        `app.reference_sharp`) adds a vertex on the sharp edge or corner of each cell
        whose normals open wider than the angle, so boxes keep their edges.  The
        extra vertices come after the plain ones; the mesh stays watertight.  The
        plain mesh is made on the chosen backend, the feature step in numpy.

    Returns ``verts`` (N, 3) float32 in array-index order times spacing,
    ``faces`` (M, 3) int32, ``normals`` (N, 3) float32 unit vectors, ``values``
    (N,) float32.  Every grid edge whose ends lie on different sides of the
    level has exactly one vertex, shared by the triangles that use it.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r} is not one of {BACKENDS}")
    if method not in METHODS:
        raise ValueError(f"method {method!r} is not one of {METHODS}")
    angle = check_feature_angle(sharp_features)
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
        mesh = marching_cubes_reference(checked.data.astype(np.float32, copy=False), level, spacing, descent)
    else:
        from .extractor import Extractor
        extractor = Extractor(checked, spacing=spacing, gradient_direction=gradient_direction)
        try:
            extractor.extract(level)
            mesh = extractor.read_mesh()
        finally:
            extractor.release()
    if angle is None:
        return mesh
    return sharpen_extracted(mesh, checked.data, spacing, descent, angle)[:4]
