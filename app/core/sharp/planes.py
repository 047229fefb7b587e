"""Tangent planes from the grid samples themselves, for Extended MC (`isoscope.core.sharp.features`).

Where the field is locally linear (a signed-distance field next to a face of a box: every
sample governed by one face), a sample p with value f (less the level) and gradient g knows
the surface exactly: the plane with normal g through q = p - f g / |g|^2.  A sample is
*clean* when, along every axis, the one-sided difference ENO picks (`clean_gradient`) is
straight (its second difference under LINEAR_TOLERANCE of the step), so that g is exact.
Smooth fields (a sphere) have no clean samples, and nothing here changes their mesh.

`plane_feature_points`: a cell's feature point from the clean planes of the 6x6x6 samples
around it (planes passing within PLANE_REACH of its centre), each distinct plane counted
once, by the same QEF as Kobbelt's (`isoscope.core.sharp.qef.feature_points`), relative to the
cell's centre (so two patches of one cell on one edge share the point).  Near a corner
outside the cell, the two planes whose line is the cell's edge (a corner within
CORNER_REACH: the corner); an edge line that runs through the cell across one of its grid
edges, which has no patch, is carried there (so the flips can join the feature line).
Whether those planes open wider than the feature angle also makes the cell a feature cell:
central differences blend an edge's sides in the samples next to it (a cell cutting a box's
edge can see its mesh normals open only ~25 degrees).
"""
from __future__ import annotations

import numpy as np

from ..interpolate import trilinear_value
from .eno import edge_of_vertex, one_sided_differences

LINEAR_TOLERANCE = 1e-3  # second difference, as a fraction of the first: the field is straight there
PLANE_REACH = 1.0  # cells: a sample plane counts for a cell when it passes this close to the cell's centre
EDGE_NEIGHBOURS = np.array([o for o in np.ndindex(3, 3, 3) if sum(v != 1 for v in o) == 2]) - 1
CORNER_REACH = 0.5  # cells: a corner this close outside a cell is its point (see _plane_qef)
PLANE_GRAIN = 0.01  # planes whose normals' components and offsets (cells) round alike to this are one
MAX_PLANES = 12  # distinct planes kept per cell (the most often seen)


def level_of(field, verts, spacing):
    """The level the plain mesh was extracted at: the field interpolated along its first vertex's edge."""
    start, along, t = edge_of_vertex(verts, np.arange(1), spacing)
    f0 = field[tuple(start[0])]
    f1 = field[tuple(start[0] + along[0])]
    return float(f0 + (t[0] if len(t) else 0.0) * (f1 - f0))


def clean_gradient(field, points, spacing):
    """ENO gradients at grid points (N, 3) (`isoscope.core.sharp.eno.eno_gradient`) and whether each is exact: the
    chosen one-sided differences are straight (second difference under LINEAR_TOLERANCE of the first)."""
    grad, steps, rough = one_sided_differences(field, points, spacing)
    clean = np.ones(len(points), bool)
    for axis in range(3):
        step = steps[:, axis]
        clean &= rough[:, axis] <= LINEAR_TOLERANCE * np.maximum(np.abs(step), 1e-3 * np.abs(step).max(initial=0))
    return grad, clean


def sample_planes(field, points, spacing, level):
    """Each grid point's plane: outward unit normal (N, 3), a point on it (N, 3), clean (N,)."""
    grad, clean = clean_gradient(field, points, spacing)
    length2 = (grad ** 2).sum(axis=1)
    clean &= length2 > 0
    safe = np.where(length2 > 0, length2, 1.0)
    f = field[tuple(points.T)].astype(np.float64) - level
    anchor = points * spacing - (f / safe)[:, None] * grad
    normal = -grad / np.sqrt(safe)[:, None]
    return normal, anchor, clean


KINK_CROSSING = 0.3  # a sample plane places a vertex only if it crosses the edge at least this steeply (cosine)


def kink_vertices(field, verts, ids, spacing, level):
    """Positions (N, 3) for the plain vertices `ids`: where one end of a vertex's grid edge has a clean plane
    that crosses the edge inside it (and the other end has none), the vertex moves along its edge to that
    crossing.  Linear interpolation is exact only where the field is straight along the edge; between two
    samples governed by different sides of a box (the one outside by its x face, the one inside by its y
    face) it lands up to half a cell off the surface, and a fan to the true edge point from there folds.
    A plane's side need not be the surface there (a face's plane runs on past its edge, and a union's box
    hides faces of the other): the crossing must leave the edge's other sample reachable at the plane's
    slope (a distance field's slope bounds how fast it changes), or the vertex stays.  Where the field is
    straight the plane's crossing is linear interpolation's, so nothing moves; smooth fields have no clean
    samples.  Vertices stay EDGE_MARGIN from their edge's ends, on the same edge."""
    from ...core.layout import EDGE_MARGIN
    spacing = np.asarray(spacing, np.float64)
    start, along, t = edge_of_vertex(verts, ids, spacing)
    ends = (start, start + along)
    values = [field[tuple(end.T)].astype(np.float64) - level for end in ends]
    length = (along * spacing).sum(axis=1)  # the edge's length
    crossings = []
    for k, end in enumerate(ends):
        grad, clean = clean_gradient(field, end, spacing)
        slope = np.linalg.norm(grad, axis=1)
        rate = (grad * along * spacing).sum(axis=1)  # the plane's change from t = 0 to t = 1
        safe = np.where(rate != 0, rate, 1.0)
        at = k - values[k] / safe  # where the plane meets the level
        other = values[1 - k]
        reach = slope * np.abs((1 - k) - at) * length
        crossing = (clean & (np.abs(rate) > KINK_CROSSING * slope * length) & (at > 0) & (at < 1)
                    & (np.abs(other) <= reach * (1 + LINEAR_TOLERANCE)))
        crossings.append(np.where(crossing, at, np.nan))
    first, second = crossings
    one = np.isfinite(first) != np.isfinite(second)
    t = np.where(one, np.clip(np.where(np.isfinite(first), first, second), EDGE_MARGIN, 1 - EDGE_MARGIN), t)
    out = verts[ids].astype(np.float64)
    axis = np.argmax(along, axis=1)
    rows = np.arange(len(ids))
    out[rows, axis] = (start[rows, axis] + t) * spacing[axis]
    return out.astype(np.float32)


CELL_CORNERS = np.array([(a, b, c) for a in range(2) for b in range(2) for c in range(2)])


def any_clean_corner(field, cells, spacing):
    """Whether any of each cell's (C, 3) eight corner samples is clean (`clean_gradient`): only there can
    `plane_feature_points` find planes (a cheap test; smooth fields have none)."""
    keys = _unique_keys(np.ravel_multi_index((cells[:, None, :] + CELL_CORNERS[None]).reshape(-1, 3).T, field.shape))
    grid, at = keys
    clean = clean_gradient(field, np.stack(np.unravel_index(grid, field.shape), axis=1), spacing)[1]
    return clean[at].reshape(len(cells), 8).any(axis=1)


def _unique_keys(keys):
    """The sorted distinct keys and, per key, its index among them."""
    grid, at = np.unique(keys, return_inverse=True)
    return grid, at.reshape(-1)


NEIGHBOURHOOD = np.array([(a, b, c) for a in range(-2, 4) for b in range(-2, 4) for c in range(-2, 4)])


def plane_feature_points(field, cells, spacing, level, cos_angle, solve, occupied, chunk=2048):
    """Per cell (P, 3 grid coordinates) the QEF of the clean sample planes around it.

    `solve(positions, normals, valid, lower, upper, mass=)` is `isoscope.core.sharp.qef.feature_points`, taken
    relative to the cell's centre; `occupied(cells)` whether cells have a patch.  Returns what `solve`
    returns, whether the planes open wider than the feature angle, and the point on the cell's edge line
    where a corner just outside the cell took the point's place (else the point itself): the fallback
    where a fan to the corner folds.  Planes that repeat one another (a
    face's samples all give the same plane) share a unit weight, so a face seen by many samples does not
    drown one seen by few.  Cells go in chunks (memory)."""
    spacing = np.asarray(spacing, np.float64)
    parts = [_plane_qef(field, cells[rows], spacing, level, cos_angle, solve, occupied)
             for rows in np.array_split(np.arange(len(cells)), max(1, -(-len(cells) // chunk)))]
    return tuple(np.concatenate([part[k] for part in parts]) for k in range(6))


def _plane_qef(field, cells, spacing, level, cos_angle, solve, occupied):
    shape = np.array(field.shape)
    points = cells[:, None, :] + NEIGHBOURHOOD[None]
    inside = ((points >= 0) & (points < shape)).all(axis=2)
    key = np.ravel_multi_index(np.clip(points, 0, shape - 1).reshape(-1, 3).T, field.shape)
    grid, at = np.unique(key, return_inverse=True)  # each grid point's plane once
    normal, anchor, clean = sample_planes(field, np.stack(np.unravel_index(grid, field.shape), axis=1),
                                          spacing, level)
    plane = _plane_ids(normal, anchor, spacing)
    p = len(cells)
    at = at.reshape(p, -1)
    centre = (cells + 0.5) * spacing
    reach = np.abs(np.einsum("pwk,pwk->pw", normal[at], anchor[at] - centre[:, None, :]))
    valid = inside & clean[at] & (reach <= PLANE_REACH * spacing.min())
    # Each cell's distinct planes (a face's samples all give the same one), the most often seen first.
    rows, ids = np.nonzero(valid)
    pairs, first, seen = np.unique(rows * (plane.max() + 1) + plane[at[rows, ids]], return_index=True,
                                   return_counts=True)
    owner = pairs // (plane.max() + 1)
    order = np.lexsort((-seen, owner))
    owner, source, seen = owner[order], at[rows[first[order]], ids[first[order]]], seen[order]
    slot = np.arange(len(owner)) - np.searchsorted(owner, owner)
    keep = slot < MAX_PLANES
    width = max(3, int(slot[keep].max(initial=0)) + 1)
    pick = np.zeros((p, width), np.int64)
    valid = np.zeros((p, width), bool)
    count = np.zeros((p, width), np.int64)
    pick[owner[keep], slot[keep]], valid[owner[keep], slot[keep]] = source[keep], True
    count[owner[keep], slot[keep]] = seen[keep]
    normal, anchor = normal[pick] * valid[..., None], anchor[pick]
    both = valid[:, None, :] & valid[:, :, None]
    opens = np.where(both, np.einsum("pik,pjk->pij", normal, normal), 1.0).min(axis=(1, 2)) < cos_angle
    lower, upper = cells * spacing, (cells + 1) * spacing
    planes = (anchor, normal, valid)
    points, ok, corner, kind = solve(*planes, lower, upper, mass=centre)
    # Three sides meeting outside the cell (near a corner): the cell's edge is the line of two of them,
    # the pair whose line is on the surface (`_surface_pair`); those rows are solved again.
    beside = np.isfinite(corner).all(axis=1) & (kind != 3)
    if beside.any():
        keep = valid.copy()
        keep[beside] = _surface_pair(normal[beside], anchor[beside], valid[beside], cos_angle, centre[beside],
                                     field, spacing, level)
        planes = (anchor, planes[1] * keep[..., None], keep)
        rows = np.flatnonzero(beside)
        points[rows], ok[rows], _, kind[rows] = solve(*(part[rows] for part in planes), lower[rows], upper[rows],
                                                      mass=centre[rows])
    # A corner just outside the cell: its edges leave it in more directions than one point of a line can
    # follow; the cell takes the corner itself.
    gap = np.maximum(np.maximum(lower - corner, corner - upper), 0).max(axis=1)
    close = beside & (gap <= CORNER_REACH * spacing.min())
    line_points = np.where((close & ok)[:, None], points, corner)  # the edge line's point, where it had one
    points[close], ok = corner[close], ok | close
    # Or it passes a grid edge of the cell through the cell across it, which has no patch (its samples all
    # on one side): this patch carries the line there, as _corner_in_empty_cell does for corners.
    rows = np.flatnonzero(~ok & (kind == 2))
    best = np.full(len(rows), np.inf)
    for offset in EDGE_NEIGHBOURS:
        if not len(rows):
            break
        across = cells[rows] + offset
        empty = ~occupied(across)
        if not empty.any():
            continue
        at = np.flatnonzero(empty)  # only the rows whose neighbour there is empty
        across = across[at]
        lo, hi = across * spacing, (across + 1) * spacing
        there, there_ok, _, there_kind = solve(*(part[rows[at]] for part in planes), lo, hi,
                                               mass=(across + 0.5) * spacing)
        dist = np.linalg.norm(there - centre[rows[at]], axis=1)
        take = there_ok & (there_kind == 2) & (dist < best[at])
        points[rows[at[take]]], best[at[take]] = there[take], dist[take]
    ok[rows] |= np.isfinite(best)
    line_points = np.where(close[:, None], line_points, points)
    return points, ok, corner, kind, opens, line_points


SIDES = 4  # distinct planes considered per cell by `_surface_pair` (the most often seen)


def _surface_pair(normal, anchor, valid, cos_angle, centre, field, spacing, level):
    """Of each row's distinct planes (P, K, the most often seen first; the first SIDES of them), the two
    (opening wider than the feature angle) whose line is the cell's edge: its point nearest the cell's
    `centre` (P, 3) lies on the surface (the field, trilinear, nearest the level there), not on the line's
    continuation past a corner.  Returns which planes (P, K) those two are."""
    rows = np.arange(len(normal))
    sides = min(SIDES, normal.shape[1])
    n, a, rep_ok = normal[:, :sides], anchor[:, :sides], valid[:, :sides]
    best, best_score = np.zeros((len(normal), 2), np.int64), np.full(len(normal), np.inf)
    for i in range(sides):
        for j in range(i + 1, sides):
            c = np.einsum("pk,pk->p", n[:, i], n[:, j])
            # (not opposite planes, c = -1: two parallel faces, say of a thin slab, meet in no line)
            usable = rep_ok[:, i] & rep_ok[:, j] & (c < cos_angle) & (1 - c * c > 1e-9)
            # x = centre + alpha n_i + beta n_j on both planes
            ri = np.einsum("pk,pk->p", n[:, i], a[:, i] - centre)
            rj = np.einsum("pk,pk->p", n[:, j], a[:, j] - centre)
            det = np.where(usable, 1 - c * c, 1.0)
            alpha, beta = (ri - c * rj) / det, (rj - c * ri) / det
            x = centre + alpha[:, None] * n[:, i] + beta[:, None] * n[:, j]
            score = np.abs(trilinear_value(field, x / spacing) - level)
            better = usable & (score < best_score)
            best[better], best_score[better] = (i, j), score[better]
    found = np.isfinite(best_score)
    out = np.zeros(valid.shape, bool)
    out[rows, best[:, 0]], out[rows, best[:, 1]] = found, found
    return out


def _plane_ids(normal, anchor, spacing):
    """An id per plane (N): planes whose normals and offsets agree to PLANE_GRAIN share one."""
    offset = np.einsum("nk,nk->n", normal, anchor) / spacing.min()
    quantised = np.rint(np.concatenate([normal, offset[:, None]], axis=1) / PLANE_GRAIN).astype(np.int64)
    return np.unique(quantised, axis=0, return_inverse=True)[1].reshape(-1)
