"""Fans to the feature vertices, the test that none folds, and the edge flips
(`isoscope.core.sharp.features`, steps 1 and 2).

A feature patch is replaced by a fan from its vertex to the patch's boundary loop (`_fans`); a
fan that turns a triangle over (`_turned_over`) tries the next candidate point (`_unfolded`).
Edges between two fans' bases are flipped to join their apexes (`_flip_edges`).
"""
from __future__ import annotations

import numpy as np

from .arrays import _first_rows, _row_counts, _unique

FOLD_SIDE_COS = -0.3  # a fan triangle turned further than this (cosine) from both its base's side normals folds
FOLD_COS = -0.3  # a fan triangle turned further than this (cosine) from the plain triangle it replaces folds
FLAT_SINE = 1e-4  # a fan triangle whose apex is this close (sine of the angle at its base) to its base's line is flat


def _plain_normals(verts, triangles):
    """The (unnormalised) normals of triangles (F, 3) of plain vertices."""
    tri = verts[triangles].astype(np.float64)
    return np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


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


def _in_feature(candidate, is_feature, patch):
    """Which faces (of all) belong to feature patches (`patch`: the candidate faces' patch ids)."""
    out = np.zeros(len(candidate), bool)
    out[np.flatnonzero(candidate)[is_feature[patch]]] = True
    return out


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
