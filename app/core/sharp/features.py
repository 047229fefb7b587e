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
     own tangent planes (`isoscope.core.sharp.planes`) decide instead: candidate cells (mesh
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

This module is the driver (`sharpen`); the steps live beside it in isoscope.core.sharp:
`cells` (which cells to look at, and the early-out bound `vertex_may_bend`), `patches` (a cell's
loops and the feature test), `planes` (the grid samples' own tangent planes), `eno` (ENO normals),
`qef` (where planes meet), `points` (each feature patch's vertex), `merge` (patches that share a
corner), `fans` (fans, the fold test and the edge flips), `normals` (the new vertices' and crisp
normals for drawing) and `arrays` (sort-based id helpers).
"""
from __future__ import annotations

import numpy as np

from ...errors import InputError, IsoscopeError
from .arrays import _padded, _unique
from .cells import CANDIDATE_FRACTION, _normal_spread, _occupancy, _plane_cells, cell_runs, vertex_may_bend
from .eno import eno_normals
from .fans import _fans, _flip_edges, _in_feature, _patch_mass, _plain_normals, _unfolded
from .merge import _merge_coincident, _split_fans
from .normals import vertex_normals_from_faces
from .patches import MAX_PATCH_VERTICES, _one_ring, _opens_wider, _patches
from .planes import kink_vertices, level_of, plane_feature_points
from .points import _corner_in_empty_cell, patch_points
from .qef import feature_points

SOLVER_CORNER_REACH = 0.3  # cells: the solver's corner this close to a cell beats the sample planes' line
SOLVER_DRIFT = 1.0  # cells: the solver's point this far from the sample planes' exact one is no fallback for it
FOLD_RETREAT = (0.25, 0.5, 0.75, 1.0)  # fractions of the way to the patch's mass point tried when a fan folds


def check_feature_angle(sharp_features) -> float | None:
    """None, or the feature angle in degrees, strictly between 0 and 180."""
    if sharp_features is None:
        return None
    try:
        angle = float(sharp_features)
    except (TypeError, ValueError):
        angle = float("nan")
    if not 0.0 < angle < 180.0:
        raise InputError(f"sharp_features={sharp_features!r} must be a feature angle in degrees between 0 and 180 "
                         "(exclusive), e.g. 30, or None for plain marching cubes")
    return angle


class Stopped(IsoscopeError):
    """`sharpen` gave up at a `stop` check (its result was no longer wanted)."""


def _check(stop) -> None:
    if stop is not None and stop.is_set():
        raise Stopped


def sharpen(mesh, field, spacing, angle, solver=patch_points, stop=None):
    """Extended MC on the plain mesh `mesh` (verts, faces, normals, values) of the signed `field`
    (it grows into the object: `signed_field`).  Returns (verts, faces, normals, values, n_plain_vertices).

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
    # Where the field is locally linear, its samples' own planes (isoscope.core.sharp.planes) say where the sides
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
    # of tests/gpu/test_sharp_features.py: a spike).
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


def signed_field(volume, descent: bool) -> np.ndarray:
    """The signed field `sharpen` takes, as a float32 copy: `volume`, negated where not `descent` (the object
    below the level), as isoscope.cpu.cubes.signed turns it."""
    return volume.astype(np.float32, copy=False) * np.float32(1.0 if descent else -1.0)


def sharpen_extracted(mesh, volume, spacing, descent, angle):
    """`sharpen` for a plain mesh of `volume` as `marching_cubes` returns it (either backend)."""
    return sharpen(mesh, signed_field(volume, descent), spacing, angle)
