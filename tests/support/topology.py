"""An oracle of the trilinear interpolant's topology, independent of isoscope's extractors: the field sampled
`refine` times per cell edge (scipy's order-1 map_coordinates is the trilinear interpolant), meshed by
scikit-image, counted (pieces, Euler characteristic) with vertices merged by position.  Where two refinements
agree the counts are taken as certain (a feature thinner than a fine cell could hide from both, rarely)."""
from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates
from skimage.measure import marching_cubes as skimage_marching_cubes

from isoscope.cpu.measure import components, euler_characteristic


def counts(verts: np.ndarray, faces: np.ndarray) -> tuple[int, int]:
    """(pieces, V - E + F) of a mesh, vertices merged by position first (scikit-image repeats some)."""
    if not len(faces):
        return 0, 0
    _, merged = np.unique(np.round(np.asarray(verts, np.float64), 6), axis=0, return_inverse=True)
    faces = merged.ravel()[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    used = np.unique(faces)
    labels = components(int(merged.max()) + 1, faces)
    return len(np.unique(labels[used])), euler_characteristic(faces)


def refined_counts(field: np.ndarray, level: float, refine: int) -> tuple[int, int]:
    axes = [np.linspace(0, n - 1, (n - 1) * refine + 1) for n in field.shape]
    fine = map_coordinates(field.astype(np.float64), np.meshgrid(*axes, indexing="ij"), order=1)
    if not (fine.min() < level < fine.max()):
        return 0, 0
    verts, faces, _, _ = skimage_marching_cubes(fine, level)
    return counts(verts, faces)


def oracle(field: np.ndarray, level: float = 0.0, refinements=(6, 12)) -> tuple[int, int] | None:
    """The trilinear interpolant's (pieces, Euler characteristic) at `level`, or None where unsure."""
    first, second = (refined_counts(field, level, r) for r in refinements)
    return first if first == second else None
