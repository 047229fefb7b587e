"""Marching cubes with the trilinear interpolant's topology, in numpy: the specification of
``topology="trilinear"`` (`isoscope.core.trilinear_table` derives its table and explains the keys).

Per cell, three decisions, all in float64 from the signed field's float32 samples minus the float32
level (exact while the two are within 2^29 of each other; rounded the same way everywhere beyond), each a
sign of products and sums taken in one fixed order, so the compiled and GPU extractors can repeat them bit
for bit:

* **The case**: corners at or above the level are inside (ties inside), as in `cubes`.
* **Each ambiguous face**: joins its inside corners when the product of their differences is at least the
  product of the outside ones' (the bilinear saddle is at or above the level).  The two cells that share
  the face multiply the same two numbers: they agree, so the mesh has no cracks.
* **The tunnel**: along axis 2 each section of the cell is bilinear; the saddle value of the section through
  vertical edges 0..3 (corners i and i + 4) is g(t) = p0 p3 - p1 p2 = A t^2 + B t + C.  Where A != 0 and
  its extremum t* = -B / 2A lies inside the cell, the section there decides: with its corners' signs
  (2A p_i(0) - B dp_i, times the sign of A) in a checkerboard, the sign of 4AC - B^2 (times the sign of A)
  says which diagonal the saddle joins.  No division is taken.

Vertices: every crossing edge's, as `cubes` places them, in the same order; then each cell's own vertices
(the mean of the listed edge vertices' positions, their normals' normalised sum, their values' mean) in
the cells' (brick, word, k) order, a cell's in the table's order.  Triangles: cells in (brick, word, k)
order, each key's triangles in the table's order.
"""
from __future__ import annotations

import numpy as np

from ..core.case_table import FACE_CORNERS
from ..core.trilinear_table import FIRST_CELL_VERTEX, case_masks, table_key, trilinear_table
from .cubes import (
    brick_order_key,
    cell_edge_ids,
    crossing_edges,
    cube_cases,
    inside_mask,
    ordered_edges,
    place_vertices,
    signed,
    vertex_of_edges,
)


def corner_differences(field: np.ndarray, level) -> list[np.ndarray]:
    """Per corner c (0..7), the float64 differences sample - level of every cell's corner c."""
    d = field.astype(np.float64) - np.float64(np.float32(level))
    n0, n1, n2 = field.shape
    return [d[c & 1: n0 - 1 + (c & 1), c >> 1 & 1: n1 - 1 + (c >> 1 & 1), c >> 2 & 1: n2 - 1 + (c >> 2 & 1)]
            for c in range(8)]


def face_keys(d: list[np.ndarray], cases: np.ndarray) -> np.ndarray:
    """Bit f set where face f of the cell is ambiguous and joins its inside corners."""
    ambiguous = case_masks()[0][cases]   # a 6-bit mask of the case's ambiguous faces
    keys = np.zeros(cases.shape, dtype=np.int64)
    for face in range(6):
        c0, c1, c2, c3 = FACE_CORNERS[face]
        first = d[c0] * d[c2]   # one diagonal's product, the other's: the same numbers in both cells
        second = d[c1] * d[c3]
        first_inside = d[c0] >= 0
        joins = np.where(first_inside, first >= second, second >= first)
        keys |= ambiguous & joins.astype(np.int64) << face
    return keys


def tunnel_keys(d: list[np.ndarray]) -> np.ndarray:
    """The section's joined diagonal at the interior extremum of its saddle value (the table's tunnel key)."""
    bottom = [d[i] for i in range(4)]
    rise = [d[i + 4] - d[i] for i in range(4)]
    a = rise[0] * rise[3] - rise[1] * rise[2]
    b = (bottom[0] * rise[3] + bottom[3] * rise[0]) - (bottom[1] * rise[2] + bottom[2] * rise[1])
    c = bottom[0] * bottom[3] - bottom[1] * bottom[2]
    sign = np.sign(a)
    inner = np.where(a < 0, (b > 0) & (b < -2 * a), (b < 0) & (b > -2 * a)) & (a != 0)
    inside = [(2 * a * bottom[i] - b * rise[i]) * sign >= 0 for i in range(4)]
    saddle = (4 * a * c - b * b) * sign
    first = inside[0] & inside[3] & ~inside[1] & ~inside[2]    # vertical edges 0 and 3 in, 1 and 2 out
    second = inside[1] & inside[2] & ~inside[0] & ~inside[3]
    keys = np.zeros(a.shape, dtype=np.int64)
    keys[inner & first] = np.where(saddle[inner & first] >= 0, 1, 4)
    keys[inner & second] = np.where(saddle[inner & second] <= 0, 2, 3)
    return keys


def trilinear_keys(field: np.ndarray, level, inside: np.ndarray) -> np.ndarray:
    """Every cell's table key (case | faces << 8 | tunnel << 14)."""
    cases = cube_cases(inside).astype(np.int64)
    d = corner_differences(field, level)
    return table_key(cases, face_keys(d, cases), tunnel_keys(d))


def keys_of_cells(field: np.ndarray, level, cells: np.ndarray) -> np.ndarray:
    """`trilinear_keys` of the cells at `cells` (N, 3) alone: the same decisions from the same eight samples
    (the chunked extraction names a box's own vertices by them, `isoscope.big.chunked`)."""
    corners = [field[cells[:, 0] + (c & 1), cells[:, 1] + (c >> 1 & 1), cells[:, 2] + (c >> 2 & 1)] for c in range(8)]
    lvl = np.float32(level)
    cases = np.zeros(len(cells), np.int64)
    for c, samples in enumerate(corners):
        cases |= (samples >= lvl).astype(np.int64) << c   # inside_mask's rule, cube_cases' bits
    d = [samples.astype(np.float64) - np.float64(lvl) for samples in corners]
    return table_key(cases, face_keys(d, cases), tunnel_keys(d))


def marching_cubes_trilinear(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True):
    """verts (N,3) float32, faces (M,3) int32, normals (N,3) float32, values (N,) float32: the mesh with the
    trilinear interpolant's topology.  `volume` as `cubes.marching_cubes_reference` takes it."""
    verts, faces, normals, values, members = trilinear_parts(volume, level, spacing, descent)
    extra_verts, extra_normals, extra_values = cell_vertex_means(verts, normals, values, members)
    return (np.concatenate([verts, extra_verts]), faces, np.concatenate([normals, extra_normals]),
            np.concatenate([values, extra_values]))


def cell_vertex_means(verts, normals, values, members):
    """The cells' own vertices from the edge vertices (verts, normals, values): per list of `members` (edge
    vertex indices in edge order), their positions' and values' means and their normals' normalised sum, in
    float32, adding the members in their order (the compiled and GPU extractors' arithmetic: `mean_vertices`)."""
    padded = np.full((len(members), max((len(which) for which in members), default=0)), -1, np.int64)
    for row, which in zip(padded, members):
        row[:len(which)] = which
    return mean_vertices(verts, normals, values, padded)


def mean_vertices(verts, normals, values, members):
    """The cells' own vertices for rows of `members` (O, M) edge vertex indices padded with -1: per row the
    members' positions' and values' means and their normals' normalised sum, in float32, each sum added a member
    at a time in the row's order (a column at a time over the rows; nothing added where a row has ended)."""
    p = np.zeros((len(members), 3), np.float32)
    n = np.zeros((len(members), 3), np.float32)
    value = np.zeros(len(members), np.float32)
    for column in members.T:
        taken = column >= 0
        p[taken] += verts[column[taken]]
        n[taken] += normals[column[taken]]
        value[taken] += values[column[taken]]
    count = (members >= 0).sum(axis=1).astype(np.float32)
    length = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
    long = length > 0
    n[long] /= length[long, None]
    return p / count[:, None], n, value / count


def trilinear_parts(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True):
    """`marching_cubes_trilinear`'s mesh before its cells' own vertices: the edge vertices' verts, the faces
    (all of them), the edge vertices' normals and values, and per own vertex its `members` (the indices of
    the edge vertices it is the mean of, in edge order), for `cell_vertex_means`."""
    table = trilinear_table()
    field, lvl = signed(volume, level, descent)
    spacing = np.asarray(spacing, dtype=np.float64)
    inside = inside_mask(field, lvl)
    points, axes = ordered_edges(crossing_edges(inside), field.shape)
    verts, normals, values = place_vertices(field, inside, lvl, points, axes, spacing, descent)
    edge_ids = np.ravel_multi_index(points.T, field.shape) * 3 + axes

    keys = trilinear_keys(field, lvl, inside)
    cells = np.argwhere(table.counts[keys] > 0)
    cells = cells[np.lexsort((cells[:, 2], brick_order_key(cells, field.shape)))]
    cell_keys = keys[tuple(cells.T)]

    # The cells' own vertices, after the edge vertices, in cell order.
    masks = table.cell_vertices[cell_keys].astype(np.int64)            # (C, most)
    own = masks > 0
    first_own = len(verts) + np.cumsum(own.ravel()).reshape(own.shape) - 1
    members = []
    for cell, slot in zip(*np.nonzero(own)):
        edges = np.array([e for e in range(12) if masks[cell, slot] >> e & 1])
        members.append(vertex_of_edges(edge_ids, cell_edge_ids(cells[cell], edges, field.shape), "trilinear table"))

    n_tri = table.counts[cell_keys].astype(np.int64)
    cell_of_tri = np.repeat(np.arange(len(cells)), n_tri)
    slot = np.arange(n_tri.sum()) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    codes = table.triangles[cell_keys[cell_of_tri], slot].astype(np.int64)     # (M, 3)
    faces = np.empty(codes.shape, dtype=np.int64)
    on_edge = codes < FIRST_CELL_VERTEX
    wanted = cell_edge_ids(cells[np.broadcast_to(cell_of_tri[:, None], codes.shape)[on_edge]], codes[on_edge],
                           field.shape)
    faces[on_edge] = vertex_of_edges(edge_ids, wanted, "trilinear table").reshape(-1)
    tri_cells = np.broadcast_to(cell_of_tri[:, None], codes.shape)[~on_edge]
    faces[~on_edge] = first_own[tri_cells, codes[~on_edge] - FIRST_CELL_VERTEX]
    return verts, faces.astype(np.int32), normals, values, members
