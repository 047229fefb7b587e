"""Each feature patch's vertex from its planes (`isoscope.core.sharp.features`; shaders/emc_solve.comp
does `patch_points` per patch on the GPU).

Only the planes near the two or three most different normals count (`_extreme_normals`), over
the patch and its one-ring when those meet in or near the cell (LINE_MARGIN), else over the
patch; a corner poking into a cell with no patch is placed by its nearest neighbouring patch
(`_corner_in_empty_cell`).
"""
from __future__ import annotations

import numpy as np

from .arrays import _unique
from .qef import feature_points

CLUSTER_ANGLE = 10.0  # degrees: normals this close to a side's own normal count as that side's
LINE_MARGIN = 0.25  # cells: how far an edge line may pass outside a cell and still count as the cell's
THIRD_SIDE_MARGIN = 1e-9  # see third_side_bound


def third_side_bound(cos_angle) -> float:
    """How far out of the plane of the two most different normals (sine) a third side's normal must lie:
    the feature angle's sine, and a margin far above rounding.  On an 8-bit scan the ENO normals come from
    whole-number differences, and a third normal lay exactly 30 degrees out (0.5 to within 2e-16), which
    numpy and the GPU's double arithmetic decided opposite ways (the MNI T1 at level 60)."""
    return float(np.sqrt(1 - cos_angle ** 2)) + THIRD_SIDE_MARGIN


def _extreme_normals(n, valid, cos_angle):
    """Which of the normals (P, W, 3) are near one of the two or three most different ones.

    Gradients by central differences blend the two sides of an edge in the samples next to it; the
    normals at the ends of the spread are the sides' own.  Seeds: the normal least like the first, the
    one least like that, and the one farthest out of the plane of those two, when it is more than the
    feature angle out.  A normal is kept when it lies within CLUSTER_ANGLE of a seed."""
    rows = np.arange(len(n))

    def dots_with(seed):  # (P, W): each normal's dot with the seed normal; 2 for padding
        return np.where(valid, np.einsum("pwk,pk->pw", n, n[rows, seed]), 2.0)

    s1 = dots_with(np.zeros(len(n), np.int64)).argmin(axis=1)
    d1 = dots_with(s1)
    s2 = d1.argmin(axis=1)
    d2 = dots_with(s2)
    # The third side's normal leaves the plane of the first two (a blend of those two stays in it).
    axis = np.cross(n[rows, s1], n[rows, s2])
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-30)
    out_of_plane = np.where(valid, np.abs(np.einsum("pwk,pk->pw", n, axis)), -1.0)
    s3 = out_of_plane.argmax(axis=1)
    third = out_of_plane[rows, s3] > third_side_bound(cos_angle)
    near = np.cos(np.radians(CLUSTER_ANGLE))
    keep = (d1 > near) | (d2 > near) | ((dots_with(s3) > near) & third[:, None])
    return keep & valid


def _solve(verts, normals, members, lower, upper, cos_angle):
    """feature_points of the vertices `members` (P, W, padded with -1), only those with extreme normals."""
    picked = np.maximum(members, 0)
    n = normals[picked].astype(np.float64)
    valid = _extreme_normals(n, members >= 0, cos_angle)
    return feature_points(verts[picked].astype(np.float64), n * valid[..., None], valid, lower, upper)


def patch_points(verts, plane_normals, members, ring_members, lower, upper, spacing, cos_angle):
    """Each feature patch's vertex: (points (P, 3), ok (P,), corners (P, 3), nan where none).

    `members` (P, MAX_PATCH_VERTICES) and `ring_members` (P, W): the patch's vertices and those with their
    neighbours, padded with -1; `lower`, `upper` (P, 3): the patch's cell.  shaders/emc_solve.comp does the
    same per patch."""
    new_points, ok = _solve(verts, plane_normals, members, lower, upper, cos_angle)[:2]
    # The sides' own normals show purer around the patch than in it (central differences blend the sides
    # in the samples next to an edge), and a corner's third side shows more often: where the planes of the
    # patch's vertices and their neighbours meet in a line through the cell, or in a point inside it, take
    # that.  (Three sides meeting outside the cell: the patch's own line is the better guess.)
    ring, ring_ok, corner, kind = _solve(verts, plane_normals, ring_members, lower, upper, cos_angle)
    two_sides = ~np.isfinite(corner).all(axis=1) & (kind == 2)
    ring_ok &= (kind == 3) | two_sides
    # The two sides' line passes near the cell but not through it (edge vertices next to an edge sit off
    # it, where linear interpolation crossed the field's kink): the point of it nearest the cell.
    margin = LINE_MARGIN * spacing
    near, near_ok = _solve(verts, plane_normals, ring_members, lower - margin, upper + margin, cos_angle)[:2]
    near_ok &= two_sides & ~ring_ok
    ring[near_ok], ring_ok = np.clip(near[near_ok], lower[near_ok], upper[near_ok]), ring_ok | near_ok
    ok &= ring_ok | ~two_sides  # the line misses the cell by more: a blend made the patch look bent
    new_points[ring_ok], ok = ring[ring_ok], ok | ring_ok
    return new_points, ok, corner


def _corner_in_empty_cell(corner, face_cells, shape, lower, upper, spacing):
    """Which patches take their corner point (P, 3; nan where none) that lies in a neighbouring cell.

    A corner that pokes less than a cell into a cell leaves all of that cell's samples outside: the cell
    has no patch to place it.  The nearest neighbouring patch whose planes meet there takes it instead,
    one patch per such cell."""
    found = np.isfinite(corner).all(axis=1)
    target = np.floor(np.where(found[:, None], corner, 0) / spacing).astype(np.int64)
    gap = np.maximum(np.maximum(lower - corner, corner - upper), 0).max(axis=1)
    found &= (gap > 0) & (gap <= spacing.min()) & (target >= 0).all(axis=1)
    found &= (target < np.array(shape) - 1).all(axis=1)
    occupied = _unique(np.ravel_multi_index(face_cells.T, np.array(shape) - 1))
    key = np.ravel_multi_index(np.where(found[:, None], target, 0).T, np.array(shape) - 1)
    at = np.minimum(np.searchsorted(occupied, key), max(len(occupied) - 1, 0))  # (np.isin hashed all cells:
    found &= ~((occupied[at] == key) if len(occupied) else np.zeros(len(key), bool))  # ~50 ms a call)
    takes = np.zeros(len(corner), bool)
    candidates = np.flatnonzero(found)
    order = candidates[np.lexsort((gap[candidates], key[candidates]))]
    _, first = np.unique(key[order], return_index=True)
    takes[order[first]] = True
    return takes
