"""ENO normals (Harten and Osher 1987) for the sharp-feature step (`isoscope.core.sharp.features`).

Central differences straddle an edge and blend its two sides; each axis's one-sided difference
from the smoother side does not (`one_sided_differences`, which the sample planes' exactness test,
`isoscope.core.sharp.planes.clean_gradient`, shares).  A vertex's normal is interpolated along its grid
edge (`edge_of_vertex`).
"""
from __future__ import annotations

import numpy as np


def edge_of_vertex(verts, ids, spacing):
    """The grid edge of each vertex `ids`, from its position: (start point (N, 3), axis mask (N, 3), t).

    A vertex lies strictly inside its edge along one axis (EDGE_MARGIN from either end) and on grid
    planes along the other two."""
    g = verts[ids].astype(np.float64) / spacing
    along = np.abs(g - np.rint(g)) > 1e-3
    start = np.where(along, np.floor(g), np.rint(g)).astype(np.int64)
    return start, along, (g - start)[along]


def one_sided_differences(field, points, spacing):
    """ENO's choice at grid points (N, 3), per axis the one-sided difference whose side is smoother (smaller
    second difference; the other where the grid ends): (gradient (N, 3), those differences (N, 3), and the
    smaller second differences (N, 3): how straight the chosen side runs)."""
    shape = np.array(field.shape)
    grad, steps, rough = (np.empty(points.shape, np.float64) for _ in range(3))
    flat_field = field.reshape(-1)
    strides = np.array([shape[1] * shape[2], shape[2], 1])
    flat = points @ strides
    f0 = flat_field[flat].astype(np.float64)
    for axis in range(3):
        k = points[:, axis]
        # Flat indices of the neighbours along the axis (clamped into the grid), gathered from 1-D.
        fp, fm, fpp, fmm = (flat_field[flat + (np.clip(k + offset, 0, shape[axis] - 1) - k) * strides[axis]]
                            .astype(np.float64) for offset in (1, -1, 2, -2))
        rough_fwd = np.where(k + 2 < shape[axis], np.abs(fpp - 2 * fp + f0), np.inf)
        rough_bwd = np.where(k - 2 >= 0, np.abs(f0 - 2 * fm + fmm), np.inf)
        use_fwd = (k == 0) | ((k + 1 < shape[axis]) & (rough_fwd < rough_bwd))
        steps[:, axis] = np.where(use_fwd, fp - f0, f0 - fm)
        grad[:, axis] = steps[:, axis] / spacing[axis]
        rough[:, axis] = np.minimum(rough_fwd, rough_bwd)
    return grad, steps, rough


def eno_gradient(field, points, spacing):
    """The field's gradient at grid points (N, 3), each axis by the one-sided difference whose side is
    smoother (smaller second difference: ENO, Harten and Osher 1987).  Central differences straddle an
    edge and blend its two sides; a one-sided difference from the flat side does not."""
    return one_sided_differences(field, points, spacing)[0]


def _eno_gradients_at(field, points, spacing):
    """eno_gradient at each of `points` (N, 3), computed once per distinct grid point (neighbouring
    vertices share their edges' ends): the same numbers, at a fraction of the gathers."""
    shape = np.array(field.shape)
    flat = np.ravel_multi_index(points.T, shape)
    unique, where = np.unique(flat, return_inverse=True)
    return eno_gradient(field, np.stack(np.unravel_index(unique, shape), axis=1), spacing)[where.reshape(-1)]


def eno_normals(field, verts, ids, spacing):
    """Outward unit normals of vertices `ids` from ENO gradients at their edge's ends, interpolated along it
    as mc_vertices.comp interpolates central differences."""
    start, along, t = edge_of_vertex(verts, ids, spacing)
    ends = _eno_gradients_at(field, np.concatenate([start, start + along]), spacing)
    grad = ends[:len(ids)] * (1 - t)[:, None] + ends[len(ids):] * t[:, None]
    length = np.linalg.norm(grad, axis=1, keepdims=True)
    return np.where(length > 0, -grad / np.where(length > 0, length, 1), 0.0)
