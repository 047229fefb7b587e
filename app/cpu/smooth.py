"""Smoothing projected back onto the level set, in numpy: the mirror of shaders/smooth_*.comp.

Per iteration every vertex moves toward the average of its mesh neighbours (the umbrella
operator, weight UMBRELLA_WEIGHT), then Newton steps on the trilinear interpolant F of the
volume pull it back onto F = level along F's gradient, inside a box of 3 cells around where
the move took it.  The level they are pulled to is corrected by the interpolant's own error:
linear interpolation across a cell misses a smooth field by t(1 - t)/2 x its second derivative
along each axis (t the position in the cell), so Newton solves F(v) - E(v) = level with
E(v) = sum over axes of t(1 - t)/2 x k, k the second differences of the samples around the
cell where the vertex starts (taken once: it moves about a cell at most), E capped at
+-CORRECTION x the value range.  Without it the smoothed vertices, which leave
the grid edges (where F is exact along the one axis that varies) for cell interiors (where all
three axes' errors add up), sink toward the concave side: on a sphere's distance field the
smoothed mesh's area came out 1.5x further below 4 pi r^2 than plain marching cubes' (-0.13%
against -0.09% at 19 cells of radius); corrected it is about half plain's error.  The cap keeps
|F(v) - level| <= (ACCEPT + CORRECTION) x the range however rough the field.

Umbrella rather than Taubin's lambda/mu pair: Taubin's second (inflating) step exists to undo
the shrinking of plain smoothing, and the projection already undoes it exactly, so one gather
per iteration does the job of two.  What is left of the move is its tangential part: the triangles
even out while the surface stays where the volume puts it.

* Neighbours: for each triangle (a, b, c) the half-edges a->b, b->c, c->a; a vertex's
  neighbours are the ends of its outgoing half-edges, so on a closed, consistently wound
  mesh each one-ring neighbour counts once.  Any indexed mesh works (cubes, tetrahedra).
* A vertex on the volume's border keeps its coordinate along that axis (the mesh's open
  edges stay on the border instead of creeping inward).
* A projection that ends further than ACCEPT x the value range off its level keeps the
  vertex where it was, so every vertex stays as close to the level set as it started.
* No triangle collapses (`keeps_triangles`): a vertex's move (umbrella and projection together)
  is kept only if each of its triangles keeps an area of at least min(its area before the move,
  MIN_AREA of a voxel face) with the triangle's other two corners where they were or where
  their own moves go (all 4 combinations: every vertex moves at once); else the vertex stays
  where it was.  Whichever moves are kept, every triangle is then one that was checked, so none
  ever falls below min(its area before smoothing, MIN_AREA): no zero-area face, no face with
  coincident corners, from any mesh that had none.
  Why: on exact ties the level set pinches to a point.  Marching cubes keeps the vertices
  around a sample equal to the level 1/256 of an edge from it (the tie rule), so those little
  caps of triangles start off the level by up to 1/256 of the range, and umbrella + projection
  pulled them into the sample itself: zero-area faces (~2,000 in 40 tie-heavy 6^3-14^3 meshes
  after one iteration, 5,000 after 12), faces with coincident corners, and the GPU
  and numpy 0.175 cell apart at one vertex.  Now such a cap stays about where marching cubes
  put it, off the level by up to 1/256 of the range: the level set has no place for it that is
  not a point.  Turning over is not checked: a triangle that turns over within one move still
  ends it above the floor, and the 4 combinations' worst cases held back vertices of
  tetrahedra's meshes (which do not start on the trilinear level set) that must move to reach it.
  The floor is a threshold like ACCEPT: where a check lands within float rounding of it, the
  GPU and numpy can decide differently (seen once in 300 random tie-heavy meshes, at the 8th
  iteration: one vertex 0.08 cell apart, closing again in later iterations).
* Normals come from the field's gradient at the new position: central differences at the
  8 corners of its cell, blended trilinearly (on a grid edge that is the extractor's normal).

Work is in index units (position / spacing); the Newton step follows the gradient in
physical units, so spacing changes the direction as it should.  Float32 throughout, in the
shaders' order of operations.
"""
from __future__ import annotations

import numpy as np

from ..core.interpolate import trilinear
from ..core.smoothing import (  # noqa: F401  (the rules both backends read; re-exported)
    ACCEPT,
    BORDER,
    CONVERGED,
    CORRECTION,
    FLOOR_SQUARED,
    MIN_AREA,
    NEWTON_STEPS,
    UMBRELLA_WEIGHT,
    check_iterations,
)
from .cubes import gradient_at, signed

F32 = np.float32


def half_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(from, to, third) of every half-edge a->b, b->c, c->a of the triangles: each half-edge's
    triangle is (from, to, third) in its winding order, so a vertex's outgoing half-edges name
    each of its triangles once."""
    faces = np.asarray(faces, np.int64)
    return faces.ravel(), faces[:, [1, 2, 0]].ravel(), faces[:, [2, 0, 1]].ravel()


def free_axes(x: np.ndarray, shape) -> np.ndarray:
    """1.0 per coordinate a vertex may move along, 0.0 where it lies on the volume's border."""
    top = np.array(shape, F32) - 1
    return ((x > BORDER) & (x < top - BORDER)).astype(F32)


def curvature(field: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per axis, the mean second difference along the 4 grid lines through x's cell along that axis,
    at the cell's two ends: (f[c-1] - f[c]) - (f[c+1] - f[c+2]) per line, c the cell; at the border,
    where one of those ends has no second difference, twice the other's; 0 along axes of fewer than 3
    samples.  Only the cell's corners and one sample beyond each end are read.  (N, 3), index units."""
    shape = np.array(field.shape)
    cell = np.clip(np.floor(x).astype(np.int64), 0, shape - 2)
    k = np.zeros(x.shape, F32)

    def at(p):
        return field[p[:, 0], p[:, 1], p[:, 2]]
    for axis in range(3):
        if shape[axis] < 3:
            continue
        others = [a for a in range(3) if a != axis]
        c = cell[:, axis]
        for u in (0, 1):
            for w in (0, 1):
                p = cell.copy()
                p[:, others[0]] += u
                p[:, others[1]] += w
                f0 = at(p)
                p[:, axis] = c + 1
                f1 = at(p)
                p[:, axis] = np.maximum(c - 1, 0)
                below = at(p)
                p[:, axis] = np.minimum(c + 2, shape[axis] - 1)
                above = at(p)
                line = np.where(c == 0, F32(2) * ((f0 - f1) - (f1 - above)),
                                np.where(c + 2 > shape[axis] - 1, F32(2) * ((below - f0) - (f0 - f1)),
                                         (below - f0) - (f1 - above)))
                k[:, axis] += line
    return k * F32(0.125)


def corrected(field, level, x, k, cap):
    """F(x) - E(x) - level and its gradient (index units), E = sum t(1 - t)/2 k capped at +-cap (see above)."""
    value, grad = trilinear(field, x)
    t = (x - np.clip(np.floor(x), 0, np.array(field.shape, F32) - 2)).astype(F32)
    error = np.sum(t * (1 - t) * F32(0.5) * k, axis=1)
    inside = np.abs(error) <= cap
    grad = grad - ((F32(0.5) - t) * k) * inside[:, None]
    return value - np.clip(error, -cap, cap) - level, grad


def project(field, level, x, free, spacing, tolerance, k, cap):
    """Newton steps from x toward F - E = level (see above, k the vertices' curvatures), inside 3 cells
    around x's cell: the end points, and whether each ended within `tolerance` of that level."""
    top = np.array(field.shape, F32) - 1
    x = np.clip(x, 0, top)
    lo = np.maximum(np.floor(x) - 1, 0).astype(F32)
    hi = np.minimum(np.floor(x) + 2, top).astype(F32)
    for step in range(NEWTON_STEPS + 1):
        residual, grad = corrected(field, level, x, k, cap)
        if step == NEWTON_STEPS:
            break
        g = grad / spacing * free  # the physical gradient, along the free axes
        gg = np.sum(g * g, axis=1)
        moving = (gg > 0) & (np.abs(residual) > F32(CONVERGED) * tolerance)
        step = np.zeros_like(x)
        step[moving] = (residual[moving] / gg[moving])[:, None] * g[moving] / spacing
        x = np.clip(x - step, lo, hi)
    return x, np.abs(residual) <= tolerance


def umbrella(x, free, starts, ends):
    """x moved UMBRELLA_WEIGHT of the way to the average of its neighbours (along half-edges), on free axes."""
    n = len(x)
    count = np.bincount(starts, minlength=n).astype(F32)
    offset = np.stack([np.bincount(starts, (x[ends, a] - x[starts, a]).astype(np.float64), minlength=n)
                       for a in range(3)], axis=1).astype(F32)
    has = count > 0
    moved = x.copy()
    moved[has] += F32(UMBRELLA_WEIGHT) * (offset[has] / count[has, None]) * free[has]
    return moved


def cross(a, b):
    """Row-wise a x b (float32, the shader's order of operations: GLSL's cross())."""
    a0, a1, a2 = a.T
    b0, b1, b2 = b.T
    return np.stack([a1 * b2 - b1 * a2, a2 * b0 - b2 * a0, a0 * b1 - b0 * a1], axis=1)


def triangle_kept(before, after):
    """Whether a triangle whose doubled area vector (edge x edge, index units) was `before` keeps
    enough area at `after`: |after|^2 >= min(|before|^2, (2 MIN_AREA)^2), in squares as the
    shader has it (no square roots)."""
    old = np.einsum("ij,ij->i", before, before)
    new = np.einsum("ij,ij->i", after, after)
    return new >= np.minimum(old, F32(FLOOR_SQUARED))


def keeps_triangles(x, y, starts, ends, thirds):
    """Per vertex, whether its move from x to y keeps each of its triangles (`triangle_kept`) with
    the triangle's other two corners at x or y: half-edge v->b of triangle (v, b, c) tries v at y
    against b and c each where it was and where it would move (4 combinations)."""
    here = x[starts]
    before = cross(x[ends] - here, x[thirds] - here)
    there = y[starts]
    ok = np.ones(len(starts), bool)
    for b in (x, y):
        for c in (x, y):
            ok &= triangle_kept(before, cross(b[ends] - there, c[thirds] - there))
    return np.bincount(starts[~ok], minlength=len(x)) == 0


def field_normals(field, x, spacing, fallback):
    """Outward unit normals from the gradient of the signed field: central differences at the
    cell's corners, blended trilinearly; `fallback` where the gradient vanishes."""
    cell = np.clip(np.floor(x).astype(np.int64), 0, np.array(field.shape) - 2)
    f = (x - cell).astype(F32)
    grad = np.zeros(x.shape, F32)
    for a in (0, 1):
        for b in (0, 1):
            for c in (0, 1):
                weight = ((f[:, 0] if a else 1 - f[:, 0]) * (f[:, 1] if b else 1 - f[:, 1])
                          * (f[:, 2] if c else 1 - f[:, 2]))
                grad += weight[:, None] * gradient_at(field, cell + [a, b, c], spacing)
    length = np.linalg.norm(grad, axis=1)
    ok = length > 0
    normals = np.asarray(fallback, F32).copy()
    normals[ok] = -grad[ok] / length[ok, None]
    return normals


def smooth_projected(verts, faces, volume, level, iterations, spacing=(1.0, 1.0, 1.0), *,
                     descent=True, normals=None, value_range=None):
    """`iterations` rounds of umbrella smoothing, each projected back onto ``volume == level``.

    verts (N, 3) in array-index order times spacing, faces (M, 3): any indexed triangle mesh
    on this volume's level set.  Returns verts, faces (the same), normals, values like
    marching_cubes.  `normals` are kept where the field is flat (default: none there).
    """
    field, lvl = signed(np.asarray(volume, F32), level, descent)
    spacing = np.asarray(spacing, F32)
    if value_range is None:
        value_range = (float(volume.min()), float(volume.max()))
    tolerance = F32(ACCEPT * (value_range[1] - value_range[0]))
    cap = F32(CORRECTION * (value_range[1] - value_range[0]))
    x = (np.asarray(verts, F32) / spacing).astype(F32)
    free = free_axes(x, field.shape)
    starts, ends, thirds = half_edges(faces)
    k = curvature(field, x)  # once, where each vertex starts: it moves about a cell at most
    for _ in range(check_iterations(iterations)):
        projected, on_level = project(field, lvl, umbrella(x, free, starts, ends), free, spacing, tolerance,
                                     k, cap)
        moved = np.where(on_level[:, None], projected, x).astype(F32)
        x = np.where(keeps_triangles(x, moved, starts, ends, thirds)[:, None], moved, x).astype(F32)
    value, _ = trilinear(field, x)
    value = value if descent else -value  # the volume's, turned back
    fallback = np.zeros_like(x) if normals is None else normals
    return (x * spacing).astype(F32), faces, field_normals(field, x, spacing, fallback), value.astype(F32)
