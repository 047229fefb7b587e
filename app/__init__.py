"""isoscope: live GPU isosurfaces of 3-D scalar fields.

    verts, faces, normals, values = isoscope.marching_cubes(volume, level)

follows scikit-image's `measure.marching_cubes` conventions; `isoscope.Extractor`
keeps a volume resident on the GPU for repeated extraction at new levels.
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["marching_cubes", "marching_tetrahedra", "smooth_mesh", "find_contours", "label_surfaces", "Extractor",
           "release_gpu_memory", "IsoscopeError", "__version__"]


def __getattr__(name):
    # Import lazily: `import app` must not need a GL driver or load every module.
    if name == "marching_cubes":
        from .api import marching_cubes
        return marching_cubes
    if name == "marching_tetrahedra":
        from .api import marching_tetrahedra
        return marching_tetrahedra
    if name == "smooth_mesh":
        from .api import smooth_mesh
        return smooth_mesh
    if name == "find_contours":
        from .core.contours import find_contours
        return find_contours
    if name == "label_surfaces":
        from .labels import label_surfaces
        return label_surfaces
    if name == "release_gpu_memory":
        from .gpu.pool import release_gpu_memory
        return release_gpu_memory
    if name == "IsoscopeError":
        from .errors import IsoscopeError
        return IsoscopeError
    if name == "Extractor":
        from .gpu.cubes import Extractor
        return Extractor
    raise AttributeError(name)
