"""scikit-image's `mask=`: a surface only in the cells where a boolean mask is true.

As in scikit-image, the cell between samples i and i + 1 along each axis is kept when the mask
is true at its far corner (i + 1, j + 1, k + 1), so a mask true on the top half of the volume
gives the surface in the top half, open where it leaves the mask.  The extraction runs on the
whole grid (on the GPU, whole bricks are as cheap as part of one); the triangles of the cells
the mask drops are removed afterwards and the vertices they alone used with them, keeping the
order of the rest.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError


def check_mask(mask, shape) -> np.ndarray | None:
    """The mask as a boolean array of the volume's `shape`, or a one-line ValueError."""
    if mask is None:
        return None
    mask = np.asarray(mask)
    if mask.shape != tuple(shape):
        raise InputError(f"mask of shape {'x'.join(map(str, mask.shape))} does not match the volume's "
                         f"{'x'.join(map(str, shape))}; give a boolean array of the volume's shape")
    if mask.dtype != np.bool_:
        raise InputError(f"mask must be a boolean array (True where the surface is wanted), not {mask.dtype}; "
                         "e.g. mask=volume_labels > 0")
    return mask


def keep_masked_cells(mesh, mask: np.ndarray, spacing, step: int = 1):
    """`mesh` (verts, faces, normals, values) without the triangles of cells the mask drops.
    `spacing`: the mesh's grid spacing (times `step` when it was made from every step-th sample)."""
    verts, faces, normals, values = mesh
    if not len(faces):
        return mesh
    # Every triangle lies inside its cell (its corners are on the cell's edges): its centroid names it.
    cells = np.floor(verts[faces].mean(axis=1) / np.asarray(spacing, np.float64)).astype(np.int64)
    far = np.minimum((cells + 1) * step, np.asarray(mask.shape) - 1)
    faces = faces[mask[far[:, 0], far[:, 1], far[:, 2]]]
    used = np.zeros(len(verts), bool)
    used[faces.ravel()] = True
    renumber = (np.cumsum(used) - 1).astype(np.int32)
    return verts[used], renumber[faces], normals[used], values[used]
