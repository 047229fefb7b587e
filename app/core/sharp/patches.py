"""Patches of a cell's triangles and the feature test (`isoscope.core.sharp.features`).

A cell's triangles form one patch per loop of edge vertices (`_patches`); a patch is a feature
when some two of its normals open wider than the feature angle (`_opens_wider`).  The solve
also looks at a patch's one-ring (`_one_ring`).
"""
from __future__ import annotations

import numpy as np

from .arrays import _padded

MAX_PATCH_VERTICES = 12  # a patch's edge vertices at most: a cell has 12 edges
OPEN_MARGIN = 0.05  # degrees: _opens_wider's margin for float32 normals (see there)


def _patches(faces: np.ndarray, face_cell: np.ndarray) -> np.ndarray:
    """A patch id per face: faces of one cell that share a vertex (transitively) share a patch."""
    n = len(faces)
    # (cell, vertex) pairs: one per face corner; a vertex lies in one loop of its cell.
    pair_ids = np.unique(np.repeat(face_cell, 3) * (faces.max() + 1) + faces.reshape(-1),
                         return_inverse=True)[1].reshape(n, 3)
    label = np.arange(n)
    while True:
        pair_label = np.full(pair_ids.max() + 1, n)
        np.minimum.at(pair_label, pair_ids.reshape(-1), np.repeat(label, 3))
        new = pair_label[pair_ids].min(axis=1)
        if np.array_equal(new, label):
            return np.unique(label, return_inverse=True)[1].reshape(-1)
        label = new


def _opens_wider(normals, members, cos_angle, angle):
    """Whether some two normals of each patch's `members` (P, W, padded with -1) meet at more than the
    feature angle: the smallest of all pairs' dots (float64) below cos_angle.

    The (P, W, W) dots are computed only for patches the normals' dots with the first member's do not
    settle: one of those below cos_angle (by more than rounding) is such a pair; all within half the
    angle less OPEN_MARGIN of it puts every pair within the angle (by the triangle inequality)."""
    valid = members >= 0
    n = normals[np.maximum(members, 0)].astype(np.float64) * valid[..., None]
    first = np.where(valid, np.einsum("pik,pk->pi", n, n[:, 0]), 1.0).min(axis=1)
    wider = first < cos_angle - 1e-12
    if angle >= 1.0:  # (a margin that beats float32 normals' rounding needs some angle)
        unsettled = np.flatnonzero(~wider & (first < np.cos(np.radians(angle / 2 - OPEN_MARGIN))))
    else:
        unsettled = np.flatnonzero(~wider)
    n, valid = n[unsettled], valid[unsettled]
    cos_open = np.einsum("pik,pjk->pij", n, n)
    both = valid[:, :, None] & valid[:, None, :]
    wider[unsettled] = np.where(both, cos_open, 1.0).min(axis=(1, 2)) < cos_angle
    return wider


def _one_ring(faces, members):
    """(P, W) the vertices of each row of `members` (padded with -1) and their neighbours in the mesh."""
    n_ids = faces.max() + 2
    wanted = np.zeros(n_ids, bool)
    wanted[members[members >= 0]] = True
    a, b, c = faces.T
    near = wanted[a] | wanted[b] | wanted[c]  # only the faces at wanted vertices have their edges
    a, b, c = a[near], b[near], c[near]
    edges = np.stack([np.concatenate([a, b, c]), np.concatenate([b, c, a])], axis=1)
    edges = edges[wanted[edges[:, 0]]]
    edges = edges[np.argsort(edges[:, 0])]  # (neighbours' order is free: _padded sorts them)
    starts = np.searchsorted(edges[:, 0], np.arange(n_ids))
    rows, cols = np.nonzero(members >= 0)
    v = members[rows, cols]
    count = starts[v + 1] - starts[v]
    nbr = edges[np.repeat(starts[v], count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count), 1]
    return _padded(np.concatenate([rows, np.repeat(rows, count)]), np.concatenate([v, nbr]), len(members))
