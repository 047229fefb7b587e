"""The marching-cubes case table, generated from a rule instead of pasted.

Geometry of one cell (offsets along array axes 0, 1, 2):

* corner ``c`` (0..7) sits at ``(c & 1, c >> 1 & 1, c >> 2 & 1)``; bit ``c`` of
  a case index is set when that corner is *inside* (its sample is on the
  object's side of the level, ties included).
* edge ``e`` (0..11) runs along axis ``a = e // 4``; its two low bits give the
  offsets along the other two axes in increasing order.  An edge is owned by
  the grid point at its lower end, which is how the extractors give every
  sign-changing grid edge exactly one shared vertex.
* face ``f`` (0..5) is the side ``f & 1`` of axis ``f // 2``.

The table is derived case by case:

1. On each face, every edge whose corners differ carries an isoline end.  A
   face with two such edges has one segment.  A face with four (the
   ambiguous checkerboard) is resolved from that face's own corners alone by
   Montani, Scateni and Scopigno's rule (1994): *inside corners are always
   separated*, each cut off by its own segment.  Two cells that share a face
   see the same four corners, so they draw the same segments there: no cracks.
2. Segments are oriented so that the inside lies on their left seen from
   outside the cell; chained, they form closed loops on the cube's surface.
3. Each loop is triangulated by the triangulation whose diagonals never join
   two points of one cube face (such a diagonal would lie in the shared face,
   where the neighbouring cell could draw it too: a non-manifold edge).  Among
   those, the one whose smallest angle is largest at edge-midpoint positions.

Triangles are wound counter-clockwise seen from outside the object.

`label_table` has the same loops (so the same segments on every face: it is as
crack-free, and its faces agree with `montani_table`'s) but folds each loop to
enclose the most volume at edge-midpoint positions, smallest angle breaking
ties.  At level 0.5 on a 0/1 indicator every vertex is a midpoint, and the
surface cuts the corners of the voxel staircase: folding a five- or six-sided
loop outwards gives back about half of what is cut (a ball 10 voxels across
loses 0.8-1.3% of its voxel volume instead of 2.2-2.5%; `app/labels.py` has
the measurements and the price).  On smooth fields the vertices are not at
midpoints, and the angle rule gives better triangles.
"""
from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np

from ..errors import InputError

CORNER_OFFSETS = np.array([(c & 1, c >> 1 & 1, c >> 2 & 1) for c in range(8)], dtype=np.int64)


def _other_axes(axis: int) -> tuple[int, int]:
    return tuple(b for b in range(3) if b != axis)  # type: ignore[return-value]


def _edge_geometry():
    axis, origin, corners = [], [], []
    for e in range(12):
        a, low = divmod(e, 4)
        b, c = _other_axes(a)
        o = [0, 0, 0]
        o[b], o[c] = low & 1, low >> 1
        end = list(o)
        end[a] = 1
        axis.append(a)
        origin.append(o)
        corners.append((o[0] | o[1] << 1 | o[2] << 2, end[0] | end[1] << 1 | end[2] << 2))
    return np.array(axis), np.array(origin), np.array(corners)


EDGE_AXIS, EDGE_ORIGIN, EDGE_CORNERS = _edge_geometry()
"""Per edge: its axis, the offset of its owning (lower) grid point, its two corners (low, high)."""


def _face_cycles() -> list[list[int]]:
    """The four corners of each face in cyclic order around it."""
    cycles = []
    for f in range(6):
        a, side = divmod(f, 2)
        b, c = _other_axes(a)
        cycle = []
        for db, dc in ((0, 0), (1, 0), (1, 1), (0, 1)):
            d = [0, 0, 0]
            d[a], d[b], d[c] = side, db, dc
            cycle.append(d[0] | d[1] << 1 | d[2] << 2)
        cycles.append(cycle)
    return cycles


FACE_CORNERS = _face_cycles()
FACE_NORMAL = np.array([[(1 if f & 1 else -1) if a == f // 2 else 0 for a in range(3)] for f in range(6)])


@cache
def _edge_between(c0: int, c1: int) -> int:
    for e, (lo, hi) in enumerate(EDGE_CORNERS):
        if {lo, hi} == {c0, c1}:
            return e
    raise InputError(f"corners {c0} and {c1} share no edge")


EDGE_MIDPOINT = (EDGE_ORIGIN + np.eye(3, dtype=np.int64)[EDGE_AXIS] * 0.5).astype(np.float64)
EDGE_FACES = [frozenset(f for f in range(6) if set(EDGE_CORNERS[e]) <= set(FACE_CORNERS[f])) for e in range(12)]


def _face_segments(case: int, face: int, joins_inside: bool = False) -> list[tuple[int, int, int]]:
    """Segments (edge_a, edge_b, reference_corner) on one face, unoriented.  An ambiguous face cuts off each
    corner of the side it does not join: Montani's rule joins the outside (`joins_inside` False); the
    trilinear topology's asymptotic decider says per face (`isoscope.core.trilinear_table`)."""
    cycle = FACE_CORNERS[face]
    inside = [bool(case >> c & 1) for c in cycle]
    crossing = [m for m in range(4) if inside[m] != inside[(m + 1) % 4]]  # edge m joins cycle[m], cycle[m+1]
    edge = lambda m: _edge_between(cycle[m], cycle[(m + 1) % 4])  # noqa: E731
    if not crossing:
        return []
    if len(crossing) == 2:
        m0, m1 = crossing
        if (m1 - m0) % 4 in (1, 3):  # adjacent edges: they cut off the corner they share
            shared = cycle[m1] if (m1 - m0) % 4 == 1 else cycle[m0]
            return [(edge(m0), edge(m1), shared)]
        return [(edge(m0), edge(m1), cycle[0])]  # opposite edges: any corner tells the side
    # Ambiguous face: cut off each corner of the side not joined (Montani 1994: the inside corners).
    return [(edge((m - 1) % 4), edge(m), cycle[m]) for m in range(4) if inside[m] != joins_inside]


def _oriented(case: int, face: int, a: int, b: int, corner: int) -> tuple[int, int]:
    """Order (a, b) so that, seen from outside the cell, the inside is on the segment's left."""
    return (a, b) if _left_of(face, a, b, corner) == bool(case >> corner & 1) else (b, a)


@cache
def _left_of(face: int, a: int, b: int, corner: int) -> bool:
    """Whether `corner` lies left of the segment from edge a's midpoint to edge b's, seen from outside."""
    pa, pb = EDGE_MIDPOINT[a], EDGE_MIDPOINT[b]
    towards_left = np.cross(pb - pa, FACE_NORMAL[face])
    return float(np.dot(towards_left, CORNER_OFFSETS[corner] - pa)) > 0


@cache
def _loops(case: int, face_key: int = 0) -> tuple[tuple[int, ...], ...]:
    """The case's closed loops of edges (both tables fold the same loops: made once per case); bit f of
    `face_key` set joins ambiguous face f's inside corners (the trilinear topology's decision)."""
    successor: dict[int, int] = {}
    for face in range(6):
        for a, b, corner in _face_segments(case, face, bool(face_key >> face & 1)):
            a, b = _oriented(case, face, a, b, corner)
            if a in successor:
                raise AssertionError(f"case {case} faces {face_key}: edge {a} starts two segments")
            successor[a] = b
    loops = []
    while successor:
        start = min(successor)
        loop = [start]
        nxt = successor.pop(start)
        while nxt != start:
            loop.append(nxt)
            nxt = successor.pop(nxt)
        loops.append(tuple(loop))
    return tuple(loops)


def _triangulations(n: int):
    """All triangulations of a convex n-gon with vertices 0..n-1, as lists of index triples."""
    @cache
    def tri(i: int, j: int) -> tuple[tuple[tuple[int, int, int], ...], ...]:
        if j - i < 2:
            return ((),)
        out = []
        for k in range(i + 1, j):
            for left in tri(i, k):
                for right in tri(k, j):
                    out.append(left + ((i, k, j),) + right)
        return tuple(out)

    return tri(0, n - 1)


@cache
def _triangle_min_angle(a: int, b: int, c: int) -> float:
    """Smallest angle of the triangle on edges (a, b, c) at their midpoints (computed once per triangle:
    a loop's triangulations share most of their triangles)."""
    return smallest_angle(EDGE_MIDPOINT[[a, b, c]])


def smallest_angle(p) -> float:
    """The smallest angle (radians) of the triangle with corners p[0], p[1], p[2]."""
    worst = np.pi
    for k in range(3):
        u, v = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
        cos = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
        worst = min(worst, float(np.arccos(np.clip(cos, -1.0, 1.0))))
    return worst


@cache
def _triangle_cone_volume(a: int, b: int, c: int) -> float:
    """Six times the signed volume of the cone from the cell centre to the triangle on edges (a, b, c)."""
    return float(np.linalg.det(EDGE_MIDPOINT[[a, b, c]] - 0.5))


def _min_angle(loop: Sequence[int], triangles) -> float:
    return min((_triangle_min_angle(*(loop[k] for k in t)) for t in triangles), default=np.pi)


def _enclosed_volume(loop: Sequence[int], triangles) -> float:
    """Signed volume of the cones from the cell centre to the triangles: triangulations of one
    loop differ in it by exactly the difference of the volume they enclose (outward winding)."""
    return float(sum(_triangle_cone_volume(*(loop[k] for k in t)) for t in triangles) / 6.0)


def _max_angle_score(loop: Sequence[int], triangles) -> tuple[float, ...]:
    return (_min_angle(loop, triangles),)


def _max_volume_score(loop: Sequence[int], triangles) -> tuple[float, ...]:
    return (round(_enclosed_volume(loop, triangles), 9), _min_angle(loop, triangles))


def _triangulate(loop: Sequence[int], score=_max_angle_score) -> list[tuple[int, int, int]]:
    """The triangulation of `loop` with no diagonal in a cube face whose `score` (a tuple,
    compared in order; the first best is kept) is largest at edge-midpoint positions."""
    n = len(loop)
    best, best_score = None, None
    for triangles in _triangulations(n):
        diagonals = {
            (min(p, q), max(p, q))
            for t in triangles for p, q in itertools.combinations(t, 2)
            if (q - p) % n not in (1, n - 1)
        }
        if any(EDGE_FACES[loop[p]] & EDGE_FACES[loop[q]] for p, q in diagonals):
            continue  # a diagonal lying in a cube face could be drawn by the neighbour too
        value = tuple(round(v, 9) for v in score(loop, triangles))
        if best_score is None or value > best_score:
            best, best_score = triangles, value
    if best is None:
        raise AssertionError(f"loop {loop}: every triangulation puts a diagonal in a face")
    return [tuple(loop[k] for k in t) for t in best]


@dataclass(frozen=True)
class CaseTable:
    """Triangles per case as cell-edge triples, padded with -1."""

    triangles: np.ndarray  # (256, max_triangles, 3) int8
    counts: np.ndarray  # (256,) uint8
    code_bits = 4  # bits per edge in packed_for_gpu (a class constant, not a field)

    @property
    def max_triangles(self) -> int:
        """The most triangles any case makes (the table's padded width)."""
        return self.triangles.shape[1]

    def packed_for_gpu(self) -> np.ndarray:
        """uint32 per (case, slot): edges e0 | e1 << 4 | e2 << 8 (code_bits apart), then 256 counts."""
        t, bits = self.triangles.astype(np.int64), self.code_bits
        packed = (t[..., 0] | t[..., 1] << bits | t[..., 2] << 2 * bits).astype(np.uint32)
        packed[t[..., 0] < 0] = 0
        return np.concatenate([packed.ravel(), self.counts.astype(np.uint32)])


@cache
def montani_table() -> CaseTable:
    """Montani's ambiguous faces, each loop folded for the largest smallest angle."""
    return _table(_max_angle_score)


@cache
def label_table() -> CaseTable:
    """The same loops, each folded to enclose the most volume: for 0/1 indicator fields (labels)."""
    return _table(_max_volume_score)


def _table(score) -> CaseTable:
    per_case = []
    for case in range(256):
        triangles = []
        for loop in _loops(case):
            triangles.extend(_triangulate(loop, score))
        per_case.append(triangles)
    return CaseTable(*padded_cases(per_case))


def padded_cases(per_case: list[list]) -> tuple[np.ndarray, np.ndarray]:
    """A table's (triangles (256, widest case, 3) int8 padded with -1, counts (256,) uint8) from each case's
    list of triangles."""
    width = max(len(t) for t in per_case)
    table = np.full((256, width, 3), -1, dtype=np.int8)
    for case, triangles in enumerate(per_case):
        if triangles:
            table[case, : len(triangles)] = triangles
    return table, np.array([len(t) for t in per_case], dtype=np.uint8)
