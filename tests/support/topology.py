"""An oracle of the trilinear interpolant's topology, independent of isoscope's extractors: the field sampled
`refine` times per cell edge (scipy's order-1 map_coordinates is the trilinear interpolant), meshed by
scikit-image, counted (pieces, Euler characteristic) with vertices merged by position.  Where two refinements
agree the counts are taken as certain (a feature thinner than a fine cell could hide from both, rarely)."""
from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates
from skimage.measure import marching_cubes as skimage_marching_cubes

from isoscope.core.case_table import CORNER_OFFSETS
from isoscope.core.trilinear_table import cell_triangles, loops, surface_regions, tunnel_corners
from isoscope.cpu.measure import components, euler_characteristic
from isoscope.cpu.trilinear import trilinear_keys


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


def single_cells(per_case: int = 200, seed: int = 0) -> dict[int, np.ndarray]:
    """A 2x2x2 grid for each table key random cells reach: per case, corner magnitudes drawn at random with
    the case's signs; the first cell of each key kept."""
    rng = np.random.default_rng(seed)
    cells = {}
    for case in range(256):
        signs = np.array([1 if case >> c & 1 else -1 for c in range(8)], np.float32)
        values = rng.uniform(0.02, 1.0, (per_case, 8)).astype(np.float32) * signs
        field = np.zeros((2, 2, 2 * per_case), np.float32)   # the cells side by side; every other cell is one
        for corner, (i, j, k) in enumerate(CORNER_OFFSETS):
            field[i, j, k::2] = values[:, corner]
        keys = trilinear_keys(field, np.float32(0), field >= 0)[0, 0, ::2]
        for m, key in enumerate(keys.tolist()):
            cells.setdefault(key, field[:, :, 2 * m: 2 * m + 2].copy())
    return cells


def configuration(key: int):
    """A key's configuration, MC33's families up to rotation and inside/outside: its loops' lengths, whether
    a tube joins two of them, how many vertices of its own the cell has."""
    case, faces, tunnel = key & 255, key >> 8 & 63, key >> 14
    corners, regions = tunnel_corners(case, tunnel), surface_regions(case, faces)
    tube = corners is not None and regions[corners[0]] != regions[corners[1]]
    return (tuple(sorted(len(loop) for loop in loops(case, faces))), tube, len(cell_triangles(case, faces, tunnel)[1]))
