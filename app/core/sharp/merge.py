"""Neighbouring feature patches whose points are one corner become one patch around one vertex
(`_merge_coincident`, for `isoscope.core.sharp.features`).
"""
from __future__ import annotations

import numpy as np

from .arrays import _first_rows, _lowest_reached, _row_counts, _unique
from .fans import _facing, _fans, _folding, _plain_normals, _turned_over

MERGE_DISTANCE = 0.05  # cells: neighbouring feature patches whose points are this close share one vertex


def _merge_coincident(sub, patch, is_feature, feature_ids, points, at_corner, spacing, verts, side_normals, n_plain):
    """Join neighbouring feature patches whose points (P, 3, rows in feature_ids order) are one corner
    (`at_corner`: the point is where three sides meet) into one patch around one feature vertex, in place
    in `patch` (the candidate faces' patch ids) and `is_feature`; returns which rows of feature_ids remain
    (each group keeps its lowest patch id and that patch's point) and the fan triangles `_split_fans`
    splits around the joined patches' inner vertices.

    A box's corner that pokes just out of its own cell is the point of that cell's patch and of the
    neighbours' its edges run into (isoscope.core.sharp.planes: CORNER_REACH).  As two vertices at one place, the fans
    between them fold: the boundary edge the two patches share gets a fan triangle from each apex, one of
    them turned over, so the fold test (`_folding`) sent one apex back toward its patch's mass point, up to
    half a cell off the corner, and the edge running from the corner kinked through it (0.32 cells off on
    the rotated box of tests/gpu/test_sharp_features.py).  Joined, that edge is inside one patch and drops out
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
