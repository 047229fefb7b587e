"""isoscope: live GPU isosurfaces of 3-D scalar fields.

    verts, faces, normals, values = isoscope.marching_cubes(volume, level)

follows scikit-image's `measure.marching_cubes` conventions; `isoscope.Extractor`
keeps a volume resident on the GPU (or, without OpenGL 4.3, in memory for the
compiled CPU kernels) for repeated extraction at new levels.
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["marching_cubes", "marching_tetrahedra", "smooth_mesh", "find_contours", "label_surfaces", "Extractor",
           "isosurface", "render", "view", "widget", "release_gpu_memory", "IsoscopeError", "__version__"]


# Each public name and the module that defines it, imported on first use: `import isoscope` must not need a
# GL driver or load every module.
_HOMES = {"marching_cubes": "api", "marching_tetrahedra": "api", "smooth_mesh": "api",
          "find_contours": "core.contours", "label_surfaces": "labels", "release_gpu_memory": "gpu.pool",
          "IsoscopeError": "errors", "Extractor": "api", "isosurface": "surface", "render": "viewer.scripting",
          "view": "viewer.scripting", "widget": "viewer.notebook"}


def __getattr__(name):
    from importlib import import_module
    if name == "api":   # `isoscope.api.outward_marching_cubes`: the public module, imported on first use too
        return import_module(".api", __name__)
    if name not in _HOMES:
        raise AttributeError(name)
    return getattr(import_module(f".{_HOMES[name]}", __name__), name)
