"""The marching tetrahedra case table (the Freudenthal split of a cell into six tetrahedra; cpu/tetra.py
explains it): the numpy reference and the shaders `mt_*.comp` read the same table from here."""
from __future__ import annotations

import itertools
from functools import cache

import numpy as np

from .case_table import CORNER_OFFSETS, CaseTable, padded_cases

KINDS = np.array([(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1)], dtype=np.int64)
"""The edge kinds a grid point owns: its edge to q + KINDS[kind]; the axes first, as in cubes."""

TETRAHEDRA = [[sum(1 << a for a in p[:n]) for n in range(4)] for p in itertools.permutations(range(3))]
"""The six tetrahedra of a cell, each as its four cell corners (bit a of a corner: offset along axis a)."""


def edge_code(low: int, high: int) -> int:
    """A tetrahedron edge as the table stores it: owning corner | kind << 3 (corner `low` <= `high`)."""
    kind = [tuple(k) for k in KINDS.tolist()].index(tuple(CORNER_OFFSETS[high] - CORNER_OFFSETS[low]))
    return low | kind << 3


def _midpoint(code: int) -> np.ndarray:
    return CORNER_OFFSETS[code & 7] + KINDS[code >> 3] / 2.0


def _outward(triangle, inside_corners, outside_corners):
    """The triangle wound counter-clockwise seen from the outside corners' side."""
    p = [_midpoint(c) for c in triangle]
    normal = np.cross(p[1] - p[0], p[2] - p[0])
    away = CORNER_OFFSETS[outside_corners].mean(0) - CORNER_OFFSETS[inside_corners].mean(0)
    return tuple(triangle) if np.dot(normal, away) > 0 else (triangle[0], triangle[2], triangle[1])


def tetrahedron_triangles(corners, case: int) -> list[tuple[int, int, int]]:
    """The triangles (edge codes) of one tetrahedron for a cube case (bit c: corner c inside)."""
    inside = [c for c in corners if case >> c & 1]
    outside = [c for c in corners if not case >> c & 1]
    edge = lambda a, b: edge_code(min(a, b), max(a, b))  # noqa: E731  (corners of a tetrahedron are ordered)
    if len(inside) in (1, 3):
        lone, others = (inside[0], outside) if len(inside) == 1 else (outside[0], inside)
        return [_outward([edge(lone, o) for o in others], inside, outside)]
    if len(inside) != 2:
        return []
    (a, b), (c, d) = inside, outside
    quad = [edge(a, c), edge(a, d), edge(b, d), edge(b, c)]  # in order around the quadrilateral
    # Split along the shorter diagonal (at edge midpoints): fixed per case, so both extractors agree.
    diagonal = [np.linalg.norm(_midpoint(quad[n]) - _midpoint(quad[n + 2])) for n in (0, 1)]
    if diagonal[0] > diagonal[1]:
        quad = quad[1:] + quad[:1]
    return [_outward(t, inside, outside) for t in ([quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]])]


class TetraTable(CaseTable):
    """Per cube case, the triangles of its six tetrahedra in order, as triples of edge codes
    (corner | kind << 3), packed 6 bits apart for the GPU."""

    code_bits = 6


@cache
def tetra_table() -> TetraTable:
    """The marching tetrahedra table: for each of the cube's 256 corner cases, the triangles of its six tetrahedra,
    padded to one width."""
    per_case = [[t for corners in TETRAHEDRA for t in tetrahedron_triangles(corners, case)] for case in range(256)]
    return TetraTable(*padded_cases(per_case))
