"""Which cells the sharp-feature step looks at (`isoscope.core.sharp.features`).

The plain mesh's faces come cell by cell (`cell_runs`).  A cell is bent when its mesh normals
spread wider than half the feature angle; the sample planes (`isoscope.core.sharp.planes`) look at
the cells whose normals stray CANDIDATE_FRACTION of the angle and their neighbours
(`_plane_cells`).  `vertex_may_bend` is the conservative per-vertex bound that lets the step
return the plain mesh early (the GPU's pass 0, shaders/emc_flags.comp).
"""
from __future__ import annotations

import numpy as np

from .arrays import _unique
from .planes import any_clean_corner

CANDIDATE_FRACTION = 0.25  # cells whose mesh normals stray this fraction of the angle from their mean are checked
BEND_MARGIN = 0.05  # degrees off the half-angle in vertex_may_bend: far more than float32 rounding


def _edge_starts(verts, spacing):
    """edge_of_vertex's start points of all `verts`, as three int32 columns (cell_runs' fast path)."""
    columns = []
    for axis in range(3):
        g = verts[:, axis].astype(np.float64) / spacing[axis]
        nearest = np.rint(g)
        columns.append(np.where(np.abs(g - nearest) > 1e-3, np.floor(g), nearest).astype(np.int32))
    return columns


def cell_runs(verts, faces, spacing):
    """Both extractors emit faces cell by cell: the cells (C, 3) with faces, in order, and their face counts.

    A face's cell is the least grid coordinate of its corners' edges per axis (its three corners never
    all lie on one face of the cell)."""
    a, b, c = (np.ascontiguousarray(column) for column in faces.T)  # (per column, not .min(axis=1): numpy
    # reduces short rows slowly; int32 columns gather faster)
    cells = np.stack([np.minimum(np.minimum(s[a], s[b]), s[c]) for s in _edge_starts(verts, spacing)],
                     axis=1).astype(np.int64)
    key = (cells[:, 0] * (cells[:, 1].max() + 1) + cells[:, 1]) * (cells[:, 2].max() + 1) + cells[:, 2]
    first = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    return cells[first], np.diff(np.append(first, len(faces)))


def bend_cos(angle) -> np.float32:
    """vertex_may_bend's threshold: the cosine of half the feature angle less BEND_MARGIN."""
    return np.float32(np.cos(np.radians(angle / 2 - BEND_MARGIN)))


def vertex_may_bend(verts, normals, field, spacing, angle):
    """Per vertex of a plain MC mesh of the signed field `field`, whether a cell around its edge may
    hold a feature: its normal is more than half the feature angle (less BEND_MARGIN) from some
    around cell's outward direction r_C, minus its mean gradient (or r_C is zero; or the vertex lies
    on no grid edge, as after smoothing).  Conservative: if no vertex of cell C is flagged, each of
    C's normals is within angle/2 of r_C, so any two are within the angle of each other and
    `sharpen`'s feature test (some pair of a patch's normals opening wider) fails in C.  So where no
    vertex is flagged, `sharpen` returns the plain mesh.  shaders/emc_flags.comp does the same per
    vertex, in float32 and in the edge's frame (u, w across it, ascending, a along it) as here."""
    g = verts.astype(np.float64) / np.asarray(spacing, np.float64)
    along = np.abs(g - np.rint(g)) > 1e-3
    flagged = along.sum(axis=1) != 1
    start = np.where(along, np.floor(g), np.rint(g)).astype(np.int64)
    a = along.astype(np.int64)
    u = np.where(along[:, :1], [0, 1, 0], [1, 0, 0])
    w = np.where(along[:, 2:], [0, 1, 0], [0, 0, 1])
    frame = np.stack([u, w, a], axis=1)  # (N, 3 axes of the frame, xyz)
    n = np.einsum("nfk,nk->nf", frame, normals.astype(np.float32)).astype(np.float32)
    step = (frame @ np.asarray(spacing, np.float64)).astype(np.float32)
    f = {(i, j, k): field[tuple(np.clip(start + (i - 1) * u + (j - 1) * w + k * a, 0,
                                        np.array(field.shape) - 1).T)]
         for i in range(3) for j in range(3) for k in range(2)}
    cos_half, upper = bend_cos(angle), np.array(field.shape) - 2
    for du in (0, 1):
        for dw in (0, 1):
            cell = start - (1 - du) * u - (1 - dw) * w
            exists = ~flagged & (cell >= 0).all(axis=1) & (cell <= upper).all(axis=1)
            c = {(i, j, k): f[du + i, dw + j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)}
            grad = np.stack([(c[1, 0, 0] - c[0, 0, 0]) + (c[1, 0, 1] - c[0, 0, 1])
                             + ((c[1, 1, 0] - c[0, 1, 0]) + (c[1, 1, 1] - c[0, 1, 1])),
                             (c[0, 1, 0] - c[0, 0, 0]) + (c[0, 1, 1] - c[0, 0, 1])
                             + ((c[1, 1, 0] - c[1, 0, 0]) + (c[1, 1, 1] - c[1, 0, 1])),
                             (c[0, 0, 1] - c[0, 0, 0]) + (c[0, 1, 1] - c[0, 1, 0])
                             + ((c[1, 0, 1] - c[1, 0, 0]) + (c[1, 1, 1] - c[1, 1, 0]))], axis=1) / (4 * step)
            length = np.sqrt((grad * grad).sum(axis=1))
            with np.errstate(invalid="ignore", divide="ignore"):
                dots = (n * (-grad / length[:, None])).sum(axis=1)
            flagged |= exists & (~(length > 0) | ~(dots >= cos_half))
    return flagged


def _normal_spread(faces, normals, n_tri):
    """Per cell (faces in runs of `n_tri`), the least cosine between a vertex normal and the cell's mean."""
    starts = np.cumsum(n_tri) - n_tri
    # Per axis and corner (contiguous columns gather and add faster than rows of three).
    columns = [np.ascontiguousarray(column) for column in faces.T]
    corners = [[np.ascontiguousarray(normals[:, axis])[column] for axis in range(3)] for column in columns]
    sums = np.stack([np.add.reduceat(corners[0][axis] + corners[1][axis] + corners[2][axis], starts)
                     for axis in range(3)], axis=1)
    unit = (sums / np.maximum(np.linalg.norm(sums, axis=1, keepdims=True), 1e-30)).astype(np.float32)
    mean = [np.repeat(unit[:, axis], n_tri) for axis in range(3)]
    dots = [(corner[0] * mean[0] + corner[1] * mean[1]) + corner[2] * mean[2] for corner in corners]
    return np.minimum.reduceat(np.minimum(np.minimum(dots[0], dots[1]), dots[2]), starts)


def _whole_numbers(field, cells):
    """Whether every sample at the cells' (C, 3) corners is a whole number, as in an 8- or 16-bit scan.
    There a run of samples is straight because of rounding, not because one flat side governs it, so
    the sample planes would take noise for faces: on a brain MRI (uint8) they found features all over
    and took ten times as long as the rest of the step.  (A float field whose samples all happen to be
    whole, such as a box's distance on a grid aligned with its faces, loses only the planes' accuracy.)"""
    corners = (cells[:, None, :] + np.array(list(np.ndindex(2, 2, 2)))[None]).reshape(-1, 3)
    samples = field[tuple(corners.T)]
    return bool(np.array_equal(samples, np.round(samples)))


def _plane_cells(field, all_cells, spread, cos_loose, spacing):
    """The cells `isoscope.core.sharp.planes` looks at: those whose mesh normals stray CANDIDATE_FRACTION of the angle
    (`spread` < `cos_loose`) and their neighbours (a corner's cell can see its normals barely open, the
    sides blending in all its samples; the edges leading into it open theirs), where clean samples
    (`any_clean_corner`) are near: in the cell's corners or those of cells up to two away, the reach of
    the 6x6x6 samples `plane_feature_points` takes.  None where the bent cells have no clean corner at
    all (smooth fields)."""
    loose = np.flatnonzero(spread < cos_loose)
    if _whole_numbers(field, all_cells[loose]):  # a scan's quantised samples
        return np.zeros(len(all_cells), bool)
    if not any_clean_corner(field, all_cells[loose], spacing).any():  # a smooth field: not one clean sample
        return np.zeros(len(all_cells), bool)
    cells = _dilated(all_cells, spread < cos_loose)
    near = np.flatnonzero(cells)
    clean = np.zeros(len(all_cells), bool)
    clean[near] = any_clean_corner(field, all_cells[near], spacing)
    if not clean.any():
        return clean
    return cells & _dilated(all_cells, _dilated(all_cells, clean))


def _dilated(cells, flags):
    """`flags` (per cell of `cells`, C x 3) set also on the cells next to a flagged one (26-neighbourhood)."""
    span = cells.max(axis=0) + 3
    around = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)])

    def key(c):
        return ((c[:, 0] + 1) * span[1] + c[:, 1] + 1) * span[2] + c[:, 2] + 1
    near = _unique(key((cells[flags][:, None, :] + around[None]).reshape(-1, 3)))
    return flags | np.isin(key(cells), near)


def _occupancy(cells, shape):
    """A function telling whether grid cells (N, 3) are among `cells` (those with faces)."""
    dims = np.array(shape) - 1
    keys = _unique(np.ravel_multi_index(cells.T, dims))

    def occupied(query):
        inside = ((query >= 0) & (query < dims)).all(axis=1)
        key = np.ravel_multi_index(np.clip(query, 0, dims - 1).T, dims)
        at = np.minimum(np.searchsorted(keys, key), len(keys) - 1)
        return ~inside | (keys[at] == key)
    return occupied
