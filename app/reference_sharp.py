"""Extended Marching Cubes (Kobbelt, Botsch, Schwanecke, Seidel 2001) in numpy: sharp edges and corners.

Starts from the plain marching-cubes mesh (`app.reference`) and changes it in two steps:

1. Feature vertices.  A cell's triangles form one patch per loop of edge
   vertices.  When the normals at a patch's edge vertices open wider than the
   feature angle theta (some pair meets at more than theta), the patch is a
   piece of an edge or corner: one extra vertex goes where the tangent planes
   (through each edge vertex, normal to its normal) meet in the least-squares
   sense.  That quadric is solved by SVD relative to the patch's mass point,
   with singular values under SINGULAR_CUTOFF times the largest dropped (two
   planes meet in a line: the point nearest the mass point on it), and the
   point is clamped into the cell.  The patch is replaced by a fan from that
   vertex to the patch's boundary loop, which keeps every boundary edge, so
   the mesh stays watertight and wound as before.
2. Edge flips.  Where an edge between two edge vertices has a feature vertex
   on both sides (fans of two neighbouring cells), it is flipped to join the
   two feature vertices, so the feature line runs straight from cell to cell.
   Each fan triangle has one such edge, so the flips are independent; a pair of
   feature vertices that two edges would join is left unflipped (it would
   make a non-manifold edge).

Outputs keep the plain mesh's vertices first, in their order, then the feature
vertices in patch order (cells in the plain mesh's triangle order, then their
first triangle); faces are the plain faces of cells without features, in order,
then the fans, patch by patch, each fan in boundary-edge order.
"""
from __future__ import annotations

import numpy as np

from .case_table import CaseTable, montani_table
from .reference import cells_in_triangle_order, inside_mask

SINGULAR_CUTOFF = 0.1  # singular values below this fraction of the largest are treated as zero
MAX_PATCH_VERTICES = 12  # a cell has 12 edges


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


def triangle_cells(field: np.ndarray, level: float, n_faces: int, table: CaseTable | None = None) -> np.ndarray:
    """The cell (i, j, k) of every face of the plain mesh of `field` (already sign-adjusted) at `level`."""
    table = table or montani_table()
    cells, _, n_tri = cells_in_triangle_order(inside_mask(field, level), table)
    if n_tri.sum() != n_faces:
        raise AssertionError("the mesh's faces do not come from this field's cells")
    return np.repeat(cells, n_tri, axis=0)


def _patches(faces: np.ndarray, face_cells: np.ndarray) -> np.ndarray:
    """A patch id per face: faces of one cell that share a vertex (transitively) share a patch."""
    n = len(faces)
    cell_key = np.unique(face_cells, axis=0, return_inverse=True)[1].reshape(-1)
    # (cell, vertex) pairs: one per face corner; a vertex lies in one loop of its cell.
    pair_ids = np.unique(np.stack([np.repeat(cell_key, 3), faces.reshape(-1)], axis=1),
                         axis=0, return_inverse=True)[1].reshape(n, 3)
    label = np.arange(n)
    while True:
        pair_label = np.full(pair_ids.max() + 1 if n else 0, n)
        np.minimum.at(pair_label, pair_ids.reshape(-1), np.repeat(label, 3))
        new = pair_label[pair_ids].min(axis=1)
        if np.array_equal(new, label):
            return np.unique(label, return_inverse=True)[1].reshape(-1)
        label = new


def _padded(groups, members, n_groups, width=None):
    """(G, width) unique members of each group, ascending, padded with -1."""
    pairs = np.unique(np.stack([groups, members], axis=1), axis=0)
    first = np.searchsorted(pairs[:, 0], np.arange(n_groups))
    slot = np.arange(len(pairs)) - first[pairs[:, 0]]
    out = np.full((n_groups, width or slot.max() + 1), -1, np.int64)
    out[pairs[:, 0], slot] = pairs[:, 1]
    return out


def _one_ring(faces, members):
    """(P, W) the vertices of each row of `members` (padded with -1) and their neighbours in the mesh."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = edges[np.argsort(edges[:, 0], kind="stable")]
    starts = np.searchsorted(edges[:, 0], np.arange(faces.max() + 2))
    rows, cols = np.nonzero(members >= 0)
    v = members[rows, cols]
    count = starts[v + 1] - starts[v]
    nbr = edges[np.repeat(starts[v], count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count), 1]
    return _padded(np.concatenate([rows, np.repeat(rows, count)]), np.concatenate([v, nbr]), len(members))


def feature_points(positions, normals, valid, lower, upper, want_rank=None):
    """Where the tangent planes of each patch (P, 12, 3) meet, and whether that is inside its cell.

    The quadric is solved relative to the mass point by SVD, singular values under SINGULAR_CUTOFF x the
    largest dropped.  Two kept (an edge): the planes meet in a line; the point on it nearest the mass point,
    slid along the line into the cell.  Three (a corner): the point itself.  One (no feature after all): the
    mass point moved onto the plane, clamped into the cell.  A line or point that misses the cell: not ok."""
    w = valid[..., None].astype(np.float64)
    mass = (positions * w).sum(axis=1) / w.sum(axis=1)
    a = normals * w
    b = np.einsum("pvk,pvk->pv", a, positions - mass[:, None, :])
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    keep = s > SINGULAR_CUTOFF * s[:, :1]
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    x = mass + np.einsum("pji,pj->pi", vt, inv * np.einsum("pvj,pv->pj", u, b))
    rank = keep.sum(axis=1)
    slack = 1e-6 * (upper - lower)
    ok = np.where(rank == 3, ((x >= lower - slack) & (x <= upper + slack)).all(axis=1), True)
    # Rank 2: clip the line x + t d to the cell's slabs and take the t in range nearest 0.
    d = vt[:, 2]
    safe = np.where(np.abs(d) > 1e-12, d, 1.0)
    t0, t1 = (lower - x) / safe, (upper - x) / safe
    lo = np.where(np.abs(d) > 1e-12, np.minimum(t0, t1), -np.inf).max(axis=1)
    hi = np.where(np.abs(d) > 1e-12, np.maximum(t0, t1), np.inf).min(axis=1)
    flat_ok = ((x >= lower - slack) & (x <= upper + slack)) | (np.abs(d) > 1e-12)
    line = rank == 2
    ok &= ~line | ((lo <= hi) & flat_ok.all(axis=1))
    t = np.clip(0.0, lo, hi)
    x = np.where(line[:, None], x + np.where(np.isfinite(t), t, 0.0)[:, None] * d, x)
    if want_rank is not None:
        ok &= rank == want_rank
    return np.clip(x, lower, upper), ok


def _solve(verts, normals, members, lower, upper, rank=None):
    """feature_points of the vertices `members` (P, W, padded with -1); with `rank`, ok only at that rank."""
    valid = members >= 0
    picked = np.maximum(members, 0)
    return feature_points(verts[picked].astype(np.float64), normals[picked].astype(np.float64) * valid[..., None],
                          valid, lower, upper, rank)


def _flip_edges(faces, fan_rows, apex):
    """Flip the edges joining two fans' bases toward their apexes (feature vertices), in place.

    `fan_rows`: the rows of `faces` that are fan triangles (a, b, apex) with base a -> b."""
    base = faces[fan_rows, :2]
    key = base[:, 0] * (apex.max() + 1 + faces.max()) + base[:, 1]
    rkey = base[:, 1] * (apex.max() + 1 + faces.max()) + base[:, 0]
    order = np.argsort(key)
    at = np.searchsorted(key[order], rkey)
    at = np.minimum(at, len(key) - 1)
    partner = order[at]
    matched = (key[partner] == rkey) & (np.arange(len(key)) < partner)  # each pair once, from its lower row
    first, second = np.flatnonzero(matched), partner[matched]
    f1, f2 = faces[fan_rows[first], 2], faces[fan_rows[second], 2]
    # A pair of feature vertices joined through two different edges would get one edge twice.
    joined = np.stack([np.minimum(f1, f2), np.maximum(f1, f2)], axis=1)
    _, inverse, counts = np.unique(joined, axis=0, return_inverse=True, return_counts=True)
    ok = (counts[inverse.reshape(-1)] == 1) & (f1 != f2)
    first, second, f1, f2 = first[ok], second[ok], f1[ok], f2[ok]
    a, b = base[first, 0], base[first, 1]
    # (a, b, f1) and (b, a, f2) bound the quad a -> f2 -> b -> f1; split it along f1 - f2 instead.
    faces[fan_rows[first]] = np.stack([a, f2, f1], axis=1)
    faces[fan_rows[second]] = np.stack([f2, b, f1], axis=1)
    return len(first)


def vertex_normals_from_faces(verts, faces, vertices):
    """Area-weighted mean of the face normals around each of `vertices` (unit length)."""
    tri = verts[faces].astype(np.float64)
    area_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    sums = np.zeros((len(verts), 3))
    for corner in range(3):
        np.add.at(sums, faces[:, corner], area_normals)
    picked = sums[vertices]
    return (picked / np.maximum(np.linalg.norm(picked, axis=1, keepdims=True), 1e-30)).astype(np.float32)


def sharpen(mesh, field, level, spacing, angle, table: CaseTable | None = None):
    """Extended MC on the plain mesh `mesh` (verts, faces, normals, values) of `field` (sign-adjusted, so
    inside is `field >= level`).  Returns (verts, faces, normals, values, n_plain_vertices)."""
    verts, faces, normals, values = mesh
    n_plain = len(verts)
    if len(faces) == 0:
        return (*mesh, n_plain)
    spacing = np.asarray(spacing, np.float64)
    face_cells = triangle_cells(field, level, len(faces), table)
    patch = _patches(faces, face_cells)
    n_patches = patch.max() + 1
    members = _padded(np.repeat(patch, 3), faces.reshape(-1), n_patches, MAX_PATCH_VERTICES)
    valid = members >= 0
    n = normals[np.maximum(members, 0)].astype(np.float64) * valid[..., None]
    cos_open = np.einsum("pik,pjk->pij", n, n)
    both = valid[:, :, None] & valid[:, None, :]
    is_feature = (np.where(both, cos_open, 1.0).min(axis=(1, 2)) < np.cos(np.radians(angle)))
    if not is_feature.any():
        return (*mesh, n_plain)

    feature_ids = np.flatnonzero(is_feature)
    cell_of_patch = np.zeros((n_patches, 3), np.int64)
    cell_of_patch[patch] = face_cells
    cells = cell_of_patch[feature_ids]
    lower, upper = cells * spacing, (cells + 1) * spacing
    new_points, ok = _solve(verts, normals, members[feature_ids], lower, upper)
    # A corner shows in the normals around the patch more often than in the patch's own: where the one-ring's
    # planes meet in a point inside the cell, take it.
    corner, corner_ok = _solve(verts, normals, _one_ring(faces, members[feature_ids]), lower, upper, rank=3)
    new_points[corner_ok], ok = corner[corner_ok], ok | corner_ok
    is_feature[feature_ids[~ok]] = False  # the planes meet outside the cell: keep its plain patch
    feature_ids, cells, new_points = feature_ids[ok], cells[ok], new_points[ok]
    if not len(feature_ids):
        return (*mesh, n_plain)
    new_index = np.full(n_patches, -1, np.int64)
    new_index[feature_ids] = n_plain + np.arange(len(feature_ids))

    # Fans: each feature patch's boundary edges (a directed edge whose reverse is not in the patch).
    in_feature = is_feature[patch]
    rows = np.flatnonzero(in_feature)
    edges = np.stack([faces[rows][:, [0, 1]], faces[rows][:, [1, 2]], faces[rows][:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_patch = np.repeat(patch[rows], 3)
    undirected = np.concatenate([edge_patch[:, None], np.sort(edges, axis=1)], axis=1)
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    boundary = counts[inverse.reshape(-1)] == 1
    edges, edge_patch = edges[boundary], edge_patch[boundary]
    order = np.argsort(edge_patch, kind="stable")
    fans = np.concatenate([edges[order], new_index[edge_patch[order], None]], axis=1)

    out_faces = np.concatenate([faces[~in_feature].astype(np.int64), fans])
    fan_rows = np.arange(len(out_faces) - len(fans), len(out_faces))
    _flip_edges(out_faces, fan_rows, new_index[feature_ids])

    out_verts = np.concatenate([verts, new_points.astype(np.float32)])
    new_normals = vertex_normals_from_faces(out_verts, out_faces, np.arange(n_plain, len(out_verts)))
    out_normals = np.concatenate([normals, new_normals])
    out_values = np.concatenate([values, np.full(len(feature_ids), values.dtype.type(np.mean(values)))])
    return out_verts, out_faces.astype(np.int32), out_normals, out_values, n_plain


def crisp_normals(verts, faces, normals, values, n_plain):
    """A mesh for drawing: every triangle touching a feature vertex (index >= n_plain) gets its own three
    vertices with its face normal, so shading does not smear across the edge; the rest is unchanged."""
    flat = (faces >= n_plain).any(axis=1)
    if not flat.any():
        return verts, faces, normals, values
    rows = faces[flat]
    tri = verts[rows].astype(np.float64)
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-30)
    start = len(verts)
    out_faces = faces.copy()
    out_faces[flat] = start + np.arange(3 * len(rows)).reshape(-1, 3)
    return (np.concatenate([verts, verts[rows.reshape(-1)]]), out_faces,
            np.concatenate([normals, np.repeat(face_n, 3, axis=0).astype(np.float32)]),
            np.concatenate([values, values[rows.reshape(-1)]]))


def sharpen_extracted(mesh, volume, level, spacing, descent, angle, table: CaseTable | None = None):
    """`sharpen` for a plain mesh of `volume` at `level` as `marching_cubes` returns it (either backend)."""
    sign = 1.0 if descent else -1.0
    field = volume.astype(np.float32, copy=False) * np.float32(sign)
    return sharpen(mesh, field, np.float32(sign * level), spacing, angle, table)


def marching_cubes_sharp_reference(volume, level, spacing=(1.0, 1.0, 1.0), descent=True, angle=30.0,
                                   table: CaseTable | None = None):
    """Plain MC then Extended MC: verts, faces, normals, values (feature vertices after the plain ones)."""
    from .reference import marching_cubes_reference
    mesh = marching_cubes_reference(volume, level, spacing, descent, table)
    return sharpen_extracted(mesh, volume, level, spacing, descent, angle, table)[:4]
