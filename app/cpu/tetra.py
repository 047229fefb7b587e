"""Marching tetrahedra in numpy: the same table and output order as the shaders `mt_*.comp`.

Every cube cell is split into six tetrahedra the same way, the Freudenthal (Kuhn) split
along the main diagonal: tetrahedron ``p`` (a permutation of the axes) walks from corner
(0, 0, 0) to (1, 1, 1) one axis at a time, in the order ``p``.  Why this split: it is the
same in every cell (a translation of one pattern, no alternating parity), and it cuts each
square face along the diagonal from its lowest corner to its highest one.  The cell on the
other side of that face cuts it along the same diagonal, so the two cells' tetrahedra meet
face to face (triangle to triangle) and the surface has no cracks.  The split needs no
choice at ambiguous faces: inside one tetrahedron the linear interpolant has one plane.

Every edge of every tetrahedron goes from a grid point ``q`` to ``q + d`` with ``d`` one of
the seven non-zero 0/1 vectors (`KINDS`: the three axes, the three face diagonals, the body
diagonal), so a grid point owns seven kinds of edges, and each edge whose ends differ gets
one vertex, shared by the triangles of every tetrahedron around it.

Conventions are those of `isoscope.cpu.cubes` (marching cubes): a sample is inside when
``sign * value >= sign * level`` (ties count as inside), vertices keep EDGE_MARGIN off
grid points (so a tie never makes two vertices coincide or a triangle collapse), normals
come from central differences, and triangles wind counter-clockwise seen from outside.
Output order: vertices by (brick, word in brick, kind, k); triangles by (brick, word in
brick, k), then the table's order (tetrahedron, then its one or two triangles).
"""
from __future__ import annotations

import numpy as np

from ..core.case_table import CORNER_OFFSETS
from ..core.tetra_table import KINDS, TETRAHEDRA, TetraTable, edge_code, tetra_table  # noqa: F401
from .cubes import (
    cube_cases,
    inside_mask,
    ordered_edges,
    ordered_triangles,
    place_vertices,
    signed,
    vertex_of_edges,
)


def crossing_edges(inside: np.ndarray) -> list[np.ndarray]:
    """mt_classify.comp: per kind, a mask over owning grid points of edges whose ends differ."""
    n = inside.shape
    masks = []
    for d in KINDS:
        lo = tuple(slice(0, n[a] - d[a]) for a in range(3))
        hi = tuple(slice(d[a], n[a]) for a in range(3))
        masks.append(np.pad(inside[lo] != inside[hi], [(0, int(d[a])) for a in range(3)]))
    return masks


def marching_tetrahedra_reference(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0),
                                  descent: bool = True):
    """verts (N,3) float32, faces (M,3) int32, normals (N,3) float32, values (N,) float32.

    `volume` must already be validated (3-D float32, finite, every axis >= 2).
    """
    table = tetra_table()
    field, lvl = signed(volume, level, descent)
    spacing = np.asarray(spacing, dtype=np.float64)
    inside = inside_mask(field, lvl)

    # Vertices: one per crossing edge, in the GPU's (brick, word, kind, k) order.
    points, kinds = ordered_edges(crossing_edges(inside), field.shape)
    verts, normals, values = place_vertices(field, inside, lvl, points, None, spacing, descent, steps=KINDS[kinds])

    # Triangles: mt_triangles.comp, cells in (brick, word, k) order, the table's triangles in order.
    cells, cell_of_tri, codes = ordered_triangles(table, cube_cases(inside), field.shape)

    owner = cells[cell_of_tri][:, None, :] + CORNER_OFFSETS[codes & 7]  # (M, 3 corners, 3 coords)
    wanted = np.ravel_multi_index(np.moveaxis(owner, -1, 0), field.shape) * len(KINDS) + (codes >> 3)
    faces = vertex_of_edges(np.ravel_multi_index(points.T, field.shape) * len(KINDS) + kinds, wanted,
                            "tetrahedra table")
    return verts, faces.astype(np.int32), normals, values
