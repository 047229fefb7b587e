"""Extended Marching Cubes (Kobbelt, Botsch, Schwanecke, Seidel 2001) in numpy: sharp edges and corners.

Starts from the plain marching-cubes mesh (`isoscope.cpu.cubes`) and changes it in two steps:

1. Feature vertices.  A cell's triangles form one patch per loop of edge
   vertices.  When the normals at a patch's edge vertices (the mesh's normals,
   as Kobbelt) open wider than the feature angle theta (some pair meets at
   more than theta), the patch is a piece of an edge or corner: one extra
   vertex goes where the tangent planes (through each edge vertex, normal to
   its normal) meet in the least-squares sense.  That quadric is solved
   relative to the mass point (a fixed-step Jacobi eigen-solve of its 3x3 normal
   equations, the same steps as the GPU's), with singular values under
   SINGULAR_CUTOFF times the largest dropped (two planes meet in a line: the point on it
   nearest the mass point, slid along it into the cell); the point is clamped
   into the cell.  The patch is replaced by a fan from that vertex to the
   patch's boundary loop, which keeps every boundary edge, so the mesh stays
   watertight and wound as before.  Where this departs from the paper, to cope
   with sampled fields (central differences blend the two sides of an edge in
   the samples next to it, and edge vertices there sit off the surface):
   - the planes use ENO normals (one-sided differences from the smoother
     side), and only those near the two or three most different normals
     (`_extreme_normals`), taken over the patch and its one-ring when those
     meet inside the cell (or near it, LINE_MARGIN), else over the patch;
   - a patch whose one-ring's two sides meet in a line that misses the cell
     by more than LINE_MARGIN is no feature (it only looked bent);
   - a corner that pokes into a cell with no patch is placed by the nearest
     neighbouring patch whose planes meet there (`_corner_in_empty_cell`);
   - where the field is locally linear (a signed-distance field), the grid samples'
     own tangent planes (`isoscope.cpu.sharp.planes`) decide instead: candidate cells (mesh
     normals straying CANDIDATE_FRACTION of the angle) and their neighbours become
     feature cells when those planes open wider than the angle, and take those
     planes' point.  That point is exact, but the plain edge vertices next to a kink
     sit off it (linear interpolation across the kink), so a fan to it can turn a
     triangle over: then (where that point is a corner just outside the cell) the
     point on the cell's own edge line, then the solver's point (not where it lies
     more than SOLVER_DRIFT from the planes' exact one), then points FOLD_RETREAT of
     the way to the patch's mass point are tried, and a patch whose every try folds
     stays plain (`_unfolded`); a fan triangle of no area counts as folded;
   - neighbouring patches whose points are one corner (it pokes out of its cell into theirs) become
     one patch around one vertex (`_merge_coincident`), where two fans would fold between them; a
     plain vertex inside the joined patch splits a fan triangle in three (`_split_fans`).
2. Edge flips.  Where an edge between two edge vertices has a feature vertex
   on both sides (fans of two neighbouring cells), it is flipped to join the
   two feature vertices, so the feature line runs straight from cell to cell.
   Each fan triangle has one such edge, so the flips are independent; a flip
   that would turn a triangle over or join two feature vertices at one point (a
   zero-area triangle) is left out, and a pair of feature vertices that two
   edges would join is joined through the first of them only (both would make
   one edge twice: a non-manifold edge).

Outputs keep the plain mesh's vertices first, in their order, then the feature
vertices in patch order (cells in the plain mesh's triangle order, then their
first triangle); faces are the plain faces of cells without features, in order,
then the fans, patch by patch, each fan in boundary-edge order.
"""
from __future__ import annotations

import numpy as np

from ...errors import IsoscopeError
from .planes import any_clean_corner, edge_of_vertex, kink_vertices, level_of, plane_feature_points

SINGULAR_CUTOFF = 0.1  # singular values below this fraction of the largest are treated as zero
MAX_PATCH_VERTICES = 12
LINE_MARGIN = 0.25  # cells: how far an edge line may pass outside a cell and still count as the cell's
SOLVER_CORNER_REACH = 0.3  # cells: the solver's corner this close to a cell beats the sample planes' line
CANDIDATE_FRACTION = 0.25  # cells whose mesh normals stray this fraction of the angle from their mean are checked
FOLD_SIDE_COS = -0.3  # a fan triangle turned further than this (cosine) from both its base's side normals folds
FOLD_COS = -0.3  # a fan triangle turned further than this (cosine) from the plain triangle it replaces folds
SOLVER_DRIFT = 1.0  # cells: the solver's point this far from the sample planes' exact one is no fallback for it
FLAT_SINE = 1e-4  # a fan triangle whose apex is this close (sine of the angle at its base) to its base's line is flat
FOLD_RETREAT = (0.25, 0.5, 0.75, 1.0)  # fractions of the way to the patch's mass point tried when a fan folds
CLUSTER_ANGLE = 10.0  # degrees: normals this close to a side's own normal count as that side's  # a cell has 12 edges


def check_feature_angle(sharp_features) -> float | None:
    """None, or the feature angle in degrees, strictly between 0 and 180."""
    if sharp_features is None:
        return None
    try:
        angle = float(sharp_features)
    except (TypeError, ValueError):
        angle = float("nan")
    if not 0.0 < angle < 180.0:
        raise ValueError(f"sharp_features={sharp_features!r} must be a feature angle in degrees between 0 and 180 "
                         "(exclusive), e.g. 30, or None for plain marching cubes")
    return angle


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


OPEN_MARGIN = 0.05  # degrees: _opens_wider's margin for float32 normals (see there)
BEND_MARGIN = 0.05  # degrees off the half-angle in vertex_may_bend: far more than float32 rounding


def bend_cos(angle) -> np.float32:
    """vertex_may_bend's threshold: the cosine of half the feature angle less BEND_MARGIN."""
    return np.float32(np.cos(np.radians(angle / 2 - BEND_MARGIN)))


def vertex_may_bend(verts, normals, field, spacing, angle):
    """Per vertex of a plain MC mesh of `field` (sign-adjusted), whether a cell around its edge may
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
    """The cells `sharp_planes` looks at: those whose mesh normals stray CANDIDATE_FRACTION of the angle
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


def _unique(values):
    """np.unique(values) of a 1-D integer array by a sort (np.unique's hash table is several times slower
    on the million-entry keys here; equal keys are equal, so the sort need not be stable, and numpy's
    default sort is ~4x faster than its stable one on such keys)."""
    ordered = np.sort(values)
    return ordered[np.concatenate([[True], ordered[1:] != ordered[:-1]])] if len(ordered) else ordered


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


def _row_counts(*columns):
    """For each row of the columns, how many rows equal it."""
    order = np.lexsort(columns[::-1])
    stacked = np.stack(columns, axis=1)[order]
    starts = np.flatnonzero(np.concatenate([[True], (stacked[1:] != stacked[:-1]).any(axis=1)]))
    sizes = np.diff(np.append(starts, len(order)))
    counts = np.empty(len(order), np.int64)
    counts[order] = np.repeat(sizes, sizes)
    return counts


def _padded(groups, members, n_groups, width=None):
    """(G, width) unique members of each group, ascending, padded with -1."""
    base = members.max() + 1
    group, member = np.divmod(_unique(groups * base + members), base)
    counts = np.bincount(group, minlength=n_groups)
    width = width or counts.max()
    slot = np.arange(len(group)) - np.repeat(np.cumsum(counts) - counts, counts)
    out = np.full(n_groups * width, -1, np.int64)
    out[group * width + slot] = member
    return out.reshape(n_groups, width)


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


JACOBI_SWEEPS = 6  # cyclic Jacobi sweeps of the 3x3 normal equations: double precision well before then


def symmetric_eigen(m):
    """Eigenvalues (P, 3), descending, and unit eigenvectors (P, 3, 3; column j for value j) of the
    symmetric matrices `m` (P, 3, 3): JACOBI_SWEEPS cyclic Jacobi sweeps (rotations over (0, 1), (0, 2),
    (1, 2)), then a stable sort.  A fixed number of steps, so emc_common.glsl takes the same ones."""
    a = np.array(m, np.float64)
    v = np.broadcast_to(np.eye(3), a.shape).copy()
    with np.errstate(over="ignore"):  # theta overflows for tiny off-diagonals: t = 0, no rotation (as in GLSL)
        for _ in range(JACOBI_SWEEPS):
            for p, q in ((0, 1), (0, 2), (1, 2)):
                apq = a[:, p, q]
                rotate = apq != 0.0
                theta = (a[:, q, q] - a[:, p, p]) / (2.0 * np.where(rotate, apq, 1.0))
                t = np.where(theta >= 0, 1.0, -1.0) / (np.abs(theta) + np.sqrt(theta * theta + 1.0))
                c = np.where(rotate, 1.0 / np.sqrt(t * t + 1.0), 1.0)
                s = np.where(rotate, t * c, 0.0)
                j = np.broadcast_to(np.eye(3), a.shape).copy()
                j[:, p, p], j[:, q, q], j[:, p, q], j[:, q, p] = c, c, s, -s
                a = np.transpose(j, (0, 2, 1)) @ a @ j
                v = v @ j
    values = np.diagonal(a, axis1=1, axis2=2)
    order = np.argsort(-values, axis=1, kind="stable")
    return np.take_along_axis(values, order, axis=1), np.take_along_axis(v, order[:, None, :], axis=2)


def feature_points(positions, normals, valid, lower, upper, mass=None):
    """Where the tangent planes of each patch (P, W, 3) meet: (points, ok, corners, kinds).

    The quadric is solved relative to the mass point through the eigen-decomposition of its normal
    equations (`symmetric_eigen`; the squares of the planes' singular values), singular values under
    SINGULAR_CUTOFF x the largest dropped.  Three kept and the point inside the cell: a corner, that point.
    Otherwise, with two planes' worth (the smallest dropped if need be): an edge, the line where they meet;
    the point on it nearest the mass point, slid along it into the cell.  Not ok: one plane's worth (no
    feature after all) or a line that misses the cell.  `corners`: the rank-3 points, unclamped (nan where
    rank < 3); `kinds`: 3 where the point is such a corner, 2 where it is on a line."""
    w = valid[..., None].astype(np.float64)
    if mass is None:
        mass = (positions * w).sum(axis=1) / np.maximum(w.sum(axis=1), 1.0)  # no plane: rank 0, not ok
    a = normals * w
    b = np.einsum("pvk,pvk->pv", a, positions - mass[:, None, :])
    values, vectors = symmetric_eigen(np.einsum("pvi,pvj->pij", a, a))
    along = np.einsum("pij,pi->pj", vectors, np.einsum("pvi,pv->pi", a, b))  # each eigenvector . A^T b
    keep = values > SINGULAR_CUTOFF ** 2 * values[:, :1]
    rank = keep.sum(axis=1)
    inv = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    corner = mass + np.einsum("pij,pj->pi", vectors, inv * along)
    corner = np.where(rank[:, None] == 3, corner, np.nan)
    inv[:, 2] = 0.0
    x = mass + np.einsum("pij,pj->pi", vectors, inv * along)  # on the line x + t d
    d = vectors[:, :, 2]
    slack = 1e-6 * (upper - lower)
    moving = np.abs(d) > 1e-12
    safe = np.where(moving, d, 1.0)
    t0, t1 = (lower - x) / safe, (upper - x) / safe
    lo = np.where(moving, np.minimum(t0, t1), -np.inf).max(axis=1)
    hi = np.where(moving, np.maximum(t0, t1), np.inf).min(axis=1)
    ok = (rank >= 2) & (lo <= hi) & (moving | ((x >= lower - slack) & (x <= upper + slack))).all(axis=1)
    x = x + np.where(ok, np.clip(0.0, lo, hi), 0.0)[:, None] * d
    inside = (corner >= lower - slack).all(axis=1) & (corner <= upper + slack).all(axis=1)
    x = np.where(inside[:, None], corner, x)
    return np.clip(x, lower, upper), ok | inside, corner, np.where(inside, 3, np.minimum(rank, 2))


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


def eno_gradient(field, points, spacing):
    """The field's gradient at grid points (N, 3), each axis by the one-sided difference whose side is
    smoother (smaller second difference: ENO, Harten and Osher 1987).  Central differences straddle an
    edge and blend its two sides; a one-sided difference from the flat side does not."""
    shape = np.array(field.shape)
    grad = np.empty(points.shape, np.float64)
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
        grad[:, axis] = np.where(use_fwd, fp - f0, f0 - fm) / spacing[axis]
    return grad


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


def _flip_edges(faces, fan_rows, verts=None):
    """Flip the edges joining two fans' bases toward their apexes (feature vertices), in place.

    `fan_rows`: the rows of `faces` that are fan triangles (a, b, apex) with base a -> b; `verts`: the
    positions, to leave alone flips that would fold."""
    base = faces[fan_rows, :2]
    stride = faces.max() + 1
    key, rkey = base[:, 0] * stride + base[:, 1], base[:, 1] * stride + base[:, 0]
    order = np.argsort(key)
    at = np.searchsorted(key[order], rkey)
    at = np.minimum(at, len(key) - 1)
    partner = order[at]
    matched = (key[partner] == rkey) & (np.arange(len(key)) < partner)  # each pair once, from its lower row
    first, second = np.flatnonzero(matched), partner[matched]
    f1, f2 = faces[fan_rows[first], 2], faces[fan_rows[second], 2]
    ok = f1 != f2
    first, second, f1, f2 = first[ok], second[ok], f1[ok], f2[ok]
    a, b = base[first, 0], base[first, 1]
    if verts is not None:  # a flip must not turn a triangle over, nor join two feature vertices at one point
        p = verts.astype(np.float64)
        before = np.cross(p[b] - p[a], p[f1] - p[a]) + np.cross(p[a] - p[b], p[f2] - p[b])
        after = [np.cross(p[f2] - p[a], p[f1] - p[a]), np.cross(p[b] - p[f2], p[f1] - p[f2])]
        fine = (np.einsum("fk,fk->f", after[0], before) > 0) & (np.einsum("fk,fk->f", after[1], before) > 0)
        fine &= np.linalg.norm(p[f1] - p[f2], axis=1) > 1e-6
        first, second, f1, f2, a, b = first[fine], second[fine], f1[fine], f2[fine], a[fine], b[fine]
    # Two fans that share two base edges (a patch joined by _merge_coincident meets its neighbour along two
    # of its cell's faces) flip one of them: both would make the edge joining their apexes twice.
    once = _first_rows(np.minimum(f1, f2), np.maximum(f1, f2))
    once.sort()
    first, second, f1, f2, a, b = first[once], second[once], f1[once], f2[once], a[once], b[once]
    # (a, b, f1) and (b, a, f2) bound the quad a -> f2 -> b -> f1; split it along f1 - f2 instead.
    faces[fan_rows[first]] = np.stack([a, f2, f1], axis=1)
    faces[fan_rows[second]] = np.stack([f2, b, f1], axis=1)
    return len(first)


def vertex_normals_from_faces(verts, faces, vertices):
    """Area-weighted mean of the face normals around each of `vertices` (unit length)."""
    wanted = np.zeros(len(verts), bool)
    wanted[vertices] = True
    faces = faces[wanted[faces].any(axis=1)]  # only the faces around them (the same sums, in the same order)
    tri = verts[faces].astype(np.float64)
    area_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    # Per axis one bincount over the corners, corner 0 of every face first: each vertex's sum adds the
    # same numbers in the same order as np.add.at corner by corner would (several times faster).
    corners, weights = faces.T.reshape(-1), np.tile(area_normals, (3, 1))
    picked = np.stack([np.bincount(corners, weights[:, axis], len(verts))[vertices] for axis in range(3)], axis=1)
    return (picked / np.maximum(np.linalg.norm(picked, axis=1, keepdims=True), 1e-30)).astype(np.float32)


class Stopped(IsoscopeError):
    """`sharpen` gave up at a `stop` check (its result was no longer wanted)."""


def _check(stop) -> None:
    if stop is not None and stop.is_set():
        raise Stopped


def sharpen(mesh, field, spacing, angle, solver=patch_points, stop=None):
    """Extended MC on the plain mesh `mesh` (verts, faces, normals, values) of `field` (sign-adjusted: it
    grows into the object).  Returns (verts, faces, normals, values, n_plain_vertices).

    `solver`: `patch_points` or a stand-in that computes the same (the GPU's, isoscope.gpu.sharp).
    `stop`: a threading.Event; once set, the step raises `Stopped` at its next check (a viewer's worker
    dropping a result no longer wanted)."""
    verts, faces, normals, values = mesh
    n_plain = len(verts)
    if len(faces) == 0:
        return (*mesh, n_plain)
    spacing = np.asarray(spacing, np.float64)
    cos_angle = np.cos(np.radians(angle))
    all_cells, n_tri = cell_runs(verts, faces, spacing)
    spread = _normal_spread(faces, normals, n_tri)
    bent = spread < np.cos(np.radians(angle / 2))
    # Where the field is locally linear, its samples' own planes (isoscope.cpu.sharp.planes) say where the sides
    # are; central differences blend the sides next to an edge (a cell cutting a box's edge can see its
    # normals open only 25 degrees).
    planar = _plane_cells(field, all_cells, spread, np.cos(np.radians(angle * CANDIDATE_FRACTION)), spacing)
    if planar.any() and not vertex_may_bend(verts, normals, field, spacing, angle).any():
        planar[:] = False  # as the GPU's pass 0 (emc_flags.comp): no vertex may bend, so the plain mesh
    if not (bent | planar).any():
        return (*mesh, n_plain)
    _check(stop)
    candidate = np.repeat(bent | planar, n_tri)
    face_cell = np.repeat(np.arange(len(all_cells)), n_tri)[candidate]
    sub = faces[candidate].astype(np.int64)
    patch = _patches(sub, face_cell)
    n_patches = patch.max() + 1
    members = _padded(np.repeat(patch, 3), sub.reshape(-1), n_patches, MAX_PATCH_VERTICES)
    cell_of_patch = np.zeros(n_patches, np.int64)
    cell_of_patch[patch] = face_cell
    p_points, p_corner = np.zeros((n_patches, 3)), np.full((n_patches, 3), np.nan)
    p_ok, p_open = np.zeros(n_patches, bool), np.zeros(n_patches, bool)
    p_line = np.zeros((n_patches, 3))
    linear = np.flatnonzero(planar[cell_of_patch])
    level = level_of(field, verts, spacing) if len(linear) else None
    if len(linear):
        (p_points[linear], p_ok[linear], p_corner[linear], _, p_open[linear],
         p_line[linear]) = plane_feature_points(
            field, all_cells[cell_of_patch[linear]], spacing, level, cos_angle,
            feature_points, _occupancy(all_cells, field.shape))
    # (vertex_may_bend, pass 0 on the GPU, skips all of this where no cell's mesh normals open wider than
    # the angle: a feature must keep needing two of them to, or that bound must change with it.  The
    # sample planes' features alone could break it, so they too give way to it above.)
    is_feature = _opens_wider(normals, members, cos_angle, angle) | (p_ok & p_open)
    if not is_feature.any():
        return (*mesh, n_plain)
    _check(stop)

    feature_ids = np.flatnonzero(is_feature)
    cells = all_cells[cell_of_patch[feature_ids]]
    lower, upper = cells * spacing, (cells + 1) * spacing
    ring_members = _one_ring(faces, members[feature_ids])
    needed = _unique(ring_members[ring_members >= 0])
    if level is not None:  # the sample planes are in play: they also place the vertices next to a kink
        verts = verts.copy()
        verts[needed] = kink_vertices(field, verts, needed, spacing, level)
    plane_normals = normals.astype(np.float64)
    plane_normals[needed] = eno_normals(field, verts, needed, spacing)
    _check(stop)
    solved, solved_ok, corner = solver(verts, plane_normals, members[feature_ids], ring_members, lower, upper,
                                       spacing, cos_angle)
    _check(stop)
    # The solver's own point (with its corners in empty cells): the fallback where the sample planes'
    # point folds the fan.
    own = _corner_in_empty_cell(corner, all_cells, field.shape, lower, upper, spacing)
    solved, solved_ok = np.where(own[:, None], corner, solved), solved_ok | own
    solver_corner = corner.copy()
    new_points, ok = solved.copy(), solved_ok.copy()
    p_ok, p_corner = p_ok[feature_ids], p_corner[feature_ids]
    new_points[p_ok], ok = p_points[feature_ids][p_ok], ok | p_ok
    has_corner = np.isfinite(p_corner).all(axis=1)
    corner[has_corner] = p_corner[has_corner]
    takes = _corner_in_empty_cell(corner, all_cells, field.shape, lower, upper, spacing)
    new_points[takes], ok = corner[takes], ok | takes
    # The sample planes meet in a line, the mesh's normals in a corner at the cell: a corner whose third
    # side no clean sample sees (a union's corner poking out through one sample) is the solver's.
    gap = np.maximum(np.maximum(lower - solver_corner, solver_corner - upper), 0).max(axis=1)
    seen_by_mesh = np.isfinite(solver_corner).all(axis=1) & (gap <= SOLVER_CORNER_REACH * spacing.min())
    prefer = ~has_corner & p_ok & solved_ok & seen_by_mesh
    new_points[prefer] = solved[prefer]
    at_corner = np.linalg.norm(np.where(np.isfinite(corner), corner, np.inf) - new_points, axis=1) < 1e-6
    # Where the point folds its fan, the fallbacks in order: where the planes' point is a corner just outside
    # the cell, the point on the cell's own edge line (the corner's own cell, or another neighbour, has the
    # corner); then the solver's point, unless the planes placed theirs exactly and the solver's lies more
    # than a cell from it: blended normals put it there, off the surface (0.66 cells out of the rotated box
    # of tests/test_sharp_features.py: a spike).
    from_planes = p_ok & ~prefer
    line = np.where(from_planes[:, None], p_line[feature_ids], new_points)
    drift = np.linalg.norm(solved - new_points, axis=1) > SOLVER_DRIFT * spacing.min()
    fallback = np.where((solved_ok & ~(from_planes & drift))[:, None], solved, new_points)
    is_feature[feature_ids[~ok]] = False  # the planes meet outside the cell: keep its plain patch
    feature_ids, new_points, at_corner, line, fallback = (feature_ids[ok], new_points[ok], at_corner[ok], line[ok],
                                                          fallback[ok])
    if not len(feature_ids):
        return (*mesh, n_plain)
    # Around features the sides' own (ENO) normals, which do not blend across the edge.
    side_normals = normals.copy()
    # Not where the ENO normal points into the half-space the central difference calls inside: no side
    # of an edge turns that far from the blend of both, and on a noisy 8-bit scan (the MNI T1 at 128)
    # 5,400 such normals shaded 11,000 plain faces from behind, as dark specks.
    eno = plane_normals[needed]
    pure = (np.linalg.norm(eno, axis=1) > 0.5) & (np.einsum("ij,ij->i", eno, normals[needed]) > 0.0)
    side_normals[needed[pure]] = plane_normals[needed[pure]]
    keep, splits = _merge_coincident(sub, patch, is_feature, feature_ids, new_points, at_corner, spacing, verts,
                                     side_normals, n_plain)
    feature_ids, new_points, line, fallback = feature_ids[keep], new_points[keep], line[keep], fallback[keep]
    fans, fan_patch, source = _fans(sub, patch, is_feature, feature_ids, n_plain)
    mass = _patch_mass(verts, members[feature_ids])
    candidates = [new_points, line, fallback] + [new_points + t * (mass - new_points) for t in FOLD_RETREAT]
    reference = _plain_normals(verts, sub[source])  # each fan triangle's plain triangle
    new_points, found = _unfolded(candidates, fans, fan_patch, feature_ids, verts, side_normals, reference)
    if not found.all():  # every candidate folds: the plain patch
        is_feature[feature_ids[~found]] = False
        feature_ids, new_points = feature_ids[found], new_points[found]
        if not len(feature_ids):  # the plain mesh as it came (no vertex moved by kink_vertices either)
            return (*mesh, n_plain)
        fans, fan_patch, source = _fans(sub, patch, is_feature, feature_ids, n_plain)
    _check(stop)
    fans, inner_faces, split_rows = _split_fans(fans, fan_patch, splits)
    out_faces = np.concatenate([faces[~_in_feature(candidate, is_feature, patch)].astype(np.int64), fans,
                                inner_faces])
    fan_rows = len(out_faces) - len(inner_faces) - len(fans) + np.flatnonzero(~split_rows)
    _flip_edges(out_faces, fan_rows, np.concatenate([verts, new_points.astype(np.float32)]))

    out_verts = np.concatenate([verts, new_points.astype(np.float32)])
    new_normals = vertex_normals_from_faces(out_verts, out_faces, np.arange(n_plain, len(out_verts)))
    out_normals = np.concatenate([side_normals, new_normals])
    out_values = np.concatenate([values, np.full(len(out_verts) - n_plain, values.dtype.type(np.mean(values)))])
    return out_verts, out_faces.astype(np.int32), out_normals, out_values, n_plain


MERGE_DISTANCE = 0.05  # cells: neighbouring feature patches whose points are this close share one vertex


def _merge_coincident(sub, patch, is_feature, feature_ids, points, at_corner, spacing, verts, side_normals, n_plain):
    """Join neighbouring feature patches whose points (P, 3, rows in feature_ids order) are one corner
    (`at_corner`: the point is where three sides meet) into one patch around one feature vertex, in place
    in `patch` (the candidate faces' patch ids) and `is_feature`; returns which rows of feature_ids remain
    (each group keeps its lowest patch id and that patch's point) and the fan triangles `_split_fans`
    splits around the joined patches' inner vertices.

    A box's corner that pokes just out of its own cell is the point of that cell's patch and of the
    neighbours' its edges run into (sharp_planes: CORNER_REACH).  As two vertices at one place, the fans
    between them fold: the boundary edge the two patches share gets a fan triangle from each apex, one of
    them turned over, so the fold test (`_folding`) sent one apex back toward its patch's mass point, up to
    half a cell off the corner, and the edge running from the corner kinked through it (0.32 cells off on
    the rotated box of tests/test_sharp_features.py).  Joined, that edge is inside one patch and drops out
    of the fan.  Two patches are joined only across an edge whose fan triangle turns over as it is, and
    only at corners: two fans that share two base edges join their apexes by one flip, not two, and
    points on a line (a face on a grid plane gives two patches a point each, one cell apart along the
    edge) are left as they were.  A group stays apart where its joined fan would fold, or where the joined
    patch is no disk (vertices - edges + faces = 1: one boundary loop), so that the fan stays 2-manifold
    at its apex.  Where the corner's cells all four lie around one grid edge, that edge's vertex is inside
    the joined patch, and a fan over its boundary would leave the vertex without a face: it goes inside a
    fan triangle whose base it neighboured instead, split in three around it (`_inner_splits`), and a
    group where some inner vertex finds no such triangle that stays facing the same way stays apart."""
    keep, no_splits = np.ones(len(feature_ids), bool), np.zeros((0, 4), np.int64)
    if at_corner.sum() < 2:
        return keep, no_splits
    row_of = np.full(len(is_feature), -1, np.int64)
    row_of[feature_ids] = np.arange(len(feature_ids))
    p, q = _coincident_pairs(sub, patch, feature_ids[at_corner], points, row_of, spacing, verts, side_normals,
                             n_plain)
    if not len(p):
        return keep, no_splits
    label = _lowest_reached(p, q, len(is_feature))
    original = patch.copy()
    patch[:] = label[patch]
    group = label[feature_ids]
    is_feature[feature_ids[group != feature_ids]] = False
    apart, splits = _vetted(sub, patch, _unique(group[group != feature_ids]), points, row_of, verts, side_normals,
                            n_plain)
    undo = np.isin(patch, apart)
    patch[undo] = original[undo]
    separate = np.isin(group, apart)
    is_feature[feature_ids[separate]] = True
    return (group == feature_ids) | separate, splits


def _plain_normals(verts, triangles):
    """The (unnormalised) normals of triangles (F, 3) of plain vertices."""
    tri = verts[triangles].astype(np.float64)
    return np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


def _coincident_pairs(sub, patch, cornered_ids, points, row_of, spacing, verts, side_normals, n_plain):
    """Pairs (p, q) of patches among `cornered_ids` that share a boundary edge, whose points lie within
    MERGE_DISTANCE, and whose fan triangle over that edge turns over (`_turned_over`) as it is."""
    cornered = np.zeros(len(row_of), bool)
    cornered[cornered_ids] = True
    rows = np.flatnonzero(cornered[patch])
    edges = np.stack([sub[rows][:, [0, 1]], sub[rows][:, [1, 2]], sub[rows][:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_patch = np.repeat(patch[rows], 3)
    lo, hi = edges.min(axis=1), edges.max(axis=1)
    shared = _row_counts(edge_patch, lo, hi) == 1  # boundary edges of their patch ...
    lo, hi, edge_patch = lo[shared], hi[shared], edge_patch[shared]
    order = np.lexsort((edge_patch, hi, lo))
    lo, hi, edge_patch = lo[order], hi[order], edge_patch[order]
    same = (lo[1:] == lo[:-1]) & (hi[1:] == hi[:-1])  # ... that are another patch's boundary edge too
    p, q, lo, hi = edge_patch[:-1][same], edge_patch[1:][same], lo[:-1][same], hi[:-1][same]
    close = np.linalg.norm((points[row_of[p]] - points[row_of[q]]) / spacing, axis=1) < MERGE_DISTANCE
    p, q, lo, hi = p[close], q[close], lo[close], hi[close]
    if not len(p):
        return p, q
    involved = _unique(np.concatenate([p, q]))
    is_involved = np.zeros(len(row_of), bool)
    is_involved[involved] = True
    fans, _, source = _fans(sub, patch, is_involved, involved, n_plain)
    over = _turned_over(points[row_of[involved]], fans, verts, side_normals, _plain_normals(verts, sub[source]))
    stride = int(sub.max()) + 1
    base = np.sort(fans[over, :2], axis=1)
    needed = np.isin(lo * stride + hi, _unique(base[:, 0] * stride + base[:, 1]))
    return p[needed], q[needed]


def _lowest_reached(p, q, n):
    """Connected groups of the pairs (p, q) among ids 0 .. n-1: each id's label is the lowest id it reaches."""
    label = np.arange(n)
    while True:
        low = np.minimum(label[p], label[q])
        new = label.copy()
        np.minimum.at(new, p, low)
        np.minimum.at(new, q, low)
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new


def _vetted(sub, patch, joined, points, row_of, verts, side_normals, n_plain):
    """Of the joined patches (ids in `patch`, already relabelled), those to keep apart: no disk (vertices -
    edges + faces != 1), a fan to their point that folds, or an inner vertex with no split (`_inner_splits`);
    and the splits of the others."""
    member_rows = np.flatnonzero(np.isin(patch, joined))
    corners = sub[member_rows]
    owner = np.repeat(patch[member_rows], 3)
    flat = corners.reshape(-1)
    e = np.stack([corners, np.roll(corners, -1, axis=1)], axis=2).reshape(-1, 2)
    lo, hi = e.min(axis=1), e.max(axis=1)
    n_vertices = np.bincount(owner[_first_rows(owner, flat)], minlength=len(row_of))
    n_edges = np.bincount(owner[_first_rows(owner, lo, hi)], minlength=len(row_of))
    n_faces = np.bincount(patch[member_rows], minlength=len(row_of))
    apart = joined[((n_vertices - n_edges + n_faces) != 1)[joined]]  # a disk: one boundary loop
    trial = np.setdiff1d(joined, apart)
    on_trial = np.zeros(len(row_of), bool)
    on_trial[trial] = True
    fans, fan_patch, source = _fans(sub, patch, on_trial, trial, n_plain)
    reference = _plain_normals(verts, sub[source])
    apart = np.concatenate([apart, _folding(points[row_of[trial]], fans, fan_patch, verts, side_normals, reference)])
    # A vertex inside the joined patch (the corner's cells all around its grid edge) is on none of its
    # boundary edges: it has no place in the fan, and goes inside one fan triangle whose base it neighboured.
    rim = _row_counts(owner, lo, hi) == 1
    stride = int(sub.max()) + 1
    rim_keys = _unique(np.concatenate([owner[rim] * stride + lo[rim], owner[rim] * stride + hi[rim]]))
    at = np.minimum(np.searchsorted(rim_keys, owner * stride + flat), len(rim_keys) - 1)
    inner = np.flatnonzero((rim_keys[at] != owner * stride + flat) & on_trial[owner] & ~np.isin(owner, apart))
    inner = inner[_first_rows(owner[inner], flat[inner])]
    splits, lost = _inner_splits(flat[inner], owner[inner], corners, owner, fans, fan_patch, reference,
                                 points[row_of[fan_patch]], verts)
    apart = np.concatenate([apart, lost])
    return apart, splits[~np.isin(splits[:, 3], apart)]


def _split_fans(fans, fan_patch, splits):
    """`fans` with each split of _merge_coincident applied: its fan triangle (a, b, apex) becomes (a, b, v),
    and (b, apex, v), (apex, a, v) are returned apart.  Returns (fans, the added faces, which fan rows were
    split: they are no longer fan triangles, so no flip takes them)."""
    split_rows = np.zeros(len(fans), bool)
    if not len(splits):
        return fans, np.zeros((0, 3), np.int64), split_rows
    fans = fans.copy()
    added = []
    for a, b, v, g in splits.tolist():
        row = int(np.flatnonzero((fans[:, 0] == a) & (fans[:, 1] == b) & (fan_patch == g))[0])
        apex = int(fans[row, 2])
        fans[row] = (a, b, v)
        added += [(b, apex, v), (apex, a, v)]
        split_rows[row] = True
    return fans, np.array(added, np.int64), split_rows


def _inner_splits(inner, inner_owner, corners, owner, fans, fan_patch, reference, apex, verts):
    """For each vertex `inner` (plain, inside the joined patch `inner_owner`), a fan triangle of that patch
    whose base a -> b are both its neighbours in the patch's plain faces and that splits into (a, b, v),
    (b, apex, v), (apex, a, v) with all three facing as the plain triangle it replaces (`reference`), the
    most evenly; one base per vertex.  Returns (splits (S, 4): a, b, v, patch; the patches where some
    inner vertex found none)."""
    p = verts.astype(np.float64)
    face_owner = owner[::3]
    splits, lost, used = [], [], set()
    for v, g in zip(inner.tolist(), inner_owner.tolist()):
        ring = set(corners[(face_owner == g) & (corners == v).any(axis=1)].reshape(-1).tolist()) - {v}
        best, best_score = None, 0.0
        for row in np.flatnonzero(fan_patch == g):
            a, b = int(fans[row, 0]), int(fans[row, 1])
            if a not in ring or b not in ring or (a, b) in used:
                continue
            x, r = apex[row], reference[row] / np.linalg.norm(reference[row])
            score = min(_facing(p[a], p[b], p[v], r), _facing(p[b], x, p[v], r), _facing(x, p[a], p[v], r))
            if score > best_score:
                best, best_score = (a, b, v, g), score
        if best is None:
            lost.append(g)
        else:
            used.add(best[:2])
            splits.append(best)
    return np.array(splits, np.int64).reshape(-1, 4), np.array(lost, np.int64)


def _facing(a, b, c, direction) -> float:
    """The cosine between triangle (a, b, c)'s normal and `direction`; 0 for a flat one (`_flat`)."""
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n)
    return 0.0 if _flat(length, a, b, c) else float(n @ direction / length)


def _flat(length, a, b, c):
    """Whether triangle (a, b, c), whose normal's length (twice its area) is `length`, is flat: c within
    FLAT_SINE (the sine of the angle at the base) of the line of a, b, or on them.  Relative, not an
    absolute area: a feature point a float32 rounding away from a plain vertex's line still is flat once
    the mesh is stored as float32.  Broadcasts over rows of points."""
    reach = np.maximum(np.linalg.norm(c - a, axis=-1), np.linalg.norm(c - b, axis=-1))
    return length <= FLAT_SINE * np.linalg.norm(b - a, axis=-1) * reach


def _first_rows(*columns):
    """The index of one row per distinct row of the columns."""
    order = np.lexsort(columns[::-1])
    stacked = np.stack(columns, axis=1)[order]
    return order[np.concatenate([[True], (stacked[1:] != stacked[:-1]).any(axis=1)])[:len(order)]]


def _patch_mass(verts, members):
    """The mean of each patch's vertices (P, 3; `members` padded with -1)."""
    valid = (members >= 0)[..., None]
    return (verts[np.maximum(members, 0)].astype(np.float64) * valid).sum(axis=1) / valid.sum(axis=1)


def _fans(sub, patch, is_feature, feature_ids, n_plain):
    """Each feature patch's fan: its boundary edges (a directed edge whose reverse is not in the patch),
    patch by patch, each closed by the patch's feature vertex (numbered from n_plain in feature_ids
    order)."""
    new_index = np.full(len(is_feature), -1, np.int64)
    new_index[feature_ids] = n_plain + np.arange(len(feature_ids))
    rows = np.flatnonzero(is_feature[patch])
    edges = np.stack([sub[rows][:, [0, 1]], sub[rows][:, [1, 2]], sub[rows][:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_patch = np.repeat(patch[rows], 3)
    boundary = _row_counts(edge_patch, edges.min(axis=1), edges.max(axis=1)) == 1
    edges, edge_patch, source = edges[boundary], edge_patch[boundary], np.repeat(rows, 3)[boundary]
    order = np.argsort(edge_patch, kind="stable")
    return (np.concatenate([edges[order], new_index[edge_patch[order], None]], axis=1), edge_patch[order],
            source[order])


def _unfolded(candidates, fans, fan_patch, feature_ids, verts, side_normals, reference):
    """Per feature patch the first of `candidates` (each P x 3, rows in `feature_ids` order) whose fan
    does not fold (`_folding`): (points, found)."""
    points = candidates[0].copy()
    settled = np.zeros(len(points), bool)
    is_open = np.zeros(max(int(fan_patch.max(initial=0)), int(feature_ids.max(initial=0))) + 1, bool)
    for candidate in candidates:
        open_rows = np.flatnonzero(~settled)
        if not len(open_rows):
            break
        points[open_rows] = candidate[open_rows]
        is_open[:] = False
        is_open[feature_ids[open_rows]] = True
        mine = is_open[fan_patch]  # (a mask, not np.isin, whose hash table cost ~50 ms a candidate)
        folded = np.searchsorted(feature_ids, _folding(points, fans[mine], fan_patch[mine], verts, side_normals,
                                                            reference[mine]))
        settled[open_rows] = True
        settled[folded] = False
    return points, settled


def _folding(points, fans, fan_patch, verts, side_normals, reference):
    """Which patches' fans turn a triangle over (`_turned_over`)."""
    return _unique(fan_patch[_turned_over(points, fans, verts, side_normals, reference)])


def _turned_over(points, fans, verts, side_normals, reference):
    """Which fan triangles turn over.  `fans` (F, 3): base a -> b (plain vertices), then the apex (numbered
    after `verts`, at `points`); `reference` (F, 3): the normal of the plain triangle each replaces.  Over:
    its normal turns further than FOLD_SIDE_COS from both base vertices' side normals, or further than
    FOLD_COS from the plain triangle's (the apex beyond the patch's loop).  A triangle of no area (the apex
    on its base's line, or on a base vertex: a corner where a plain vertex already is) counts as over too."""
    a, b = verts[fans[:, 0]].astype(np.float64), verts[fans[:, 1]].astype(np.float64)
    apex = points[fans[:, 2] - len(verts)]
    n = np.cross(b - a, apex - a)
    length = np.linalg.norm(n, axis=1)
    flat = _flat(length, a, b, apex)
    against = ((np.einsum("fk,fk->f", n, side_normals[fans[:, 0]]) < FOLD_SIDE_COS * length)
               & (np.einsum("fk,fk->f", n, side_normals[fans[:, 1]]) < FOLD_SIDE_COS * length))
    against |= np.einsum("fk,fk->f", n, reference) < FOLD_COS * length * np.linalg.norm(reference, axis=1)
    return against | flat


def _in_feature(candidate, is_feature, patch):
    """Which faces (of all) belong to feature patches (`patch`: the candidate faces' patch ids)."""
    out = np.zeros(len(candidate), bool)
    out[np.flatnonzero(candidate)[is_feature[patch]]] = True
    return out


def crisp_normals(verts, faces, normals, values, n_plain):
    """A mesh for drawing: every triangle touching a feature vertex (index >= n_plain) gets its own three
    vertices; at its feature corners the mean normal of its other corners (the side it lies on), so
    shading does not smear across the edge; in a mesh with feature vertices, so does every triangle with
    a corner whose normal faces away from it, and such corners get the triangle's own normal.  The rest
    is unchanged (a mesh without feature vertices is returned as it is: the plain mesh)."""
    a, b, c = faces.T  # (per column: numpy reduces short rows slowly)
    flat = (a >= n_plain) | (b >= n_plain) | (c >= n_plain)
    if not flat.any():
        return verts, faces, normals, values
    face_normals = _unit_face_normals(verts, faces)  # once: which faces a corner shades from behind, and how
    flat |= (np.einsum("fck,fk->fc", normals[faces].astype(np.float64), face_normals) < 0.0).any(axis=1)
    rows = faces[flat]
    plain = rows < n_plain
    corner_normals = normals[rows].astype(np.float64)
    weighted = [corner_normals[:, k] * plain[:, k, None] for k in range(3)]
    side = (weighted[0] + weighted[1]) + weighted[2]
    side /= np.maximum(np.sqrt((side[:, 0] * side[:, 0] + side[:, 1] * side[:, 1]) + side[:, 2] * side[:, 2]),
                       1e-30)[:, None]
    corner_normals = np.where(plain[..., None], corner_normals, side[:, None, :])
    # A corner normal more than 90 degrees from its triangle's own normal would shade the triangle from
    # behind (dark specks: on the MNI T1 at 128, thousands of fan triangles that turn 90-107 degrees,
    # which the fold test lets through to keep edges straight, and plain triangles next to them whose
    # corners took the sides' normals): such corners take the triangle's normal.
    face = face_normals[flat]
    behind = np.einsum("fck,fk->fc", corner_normals, face) < 0.0
    corner_normals = np.where(behind[..., None], face[:, None, :], corner_normals)
    start = len(verts)
    out_faces = faces.copy()
    out_faces[flat] = start + np.arange(3 * len(rows)).reshape(-1, 3)
    return (np.concatenate([verts, verts[rows.reshape(-1)]]), out_faces,
            np.concatenate([normals, corner_normals.reshape(-1, 3).astype(np.float32)]),
            np.concatenate([values, values[rows.reshape(-1)]]))


def _unit_face_normals(verts, faces):
    corners = verts[faces].astype(np.float64)
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return face / np.maximum(np.linalg.norm(face, axis=1), 1e-30)[:, None]


def signed_field(volume, descent: bool) -> np.ndarray:
    """The float32 field `sharpen` takes: `volume`, negated when the object is below the level."""
    return volume.astype(np.float32, copy=False) * np.float32(1.0 if descent else -1.0)


def sharpen_extracted(mesh, volume, spacing, descent, angle):
    """`sharpen` for a plain mesh of `volume` as `marching_cubes` returns it (either backend)."""
    return sharpen(mesh, signed_field(volume, descent), spacing, angle)
