"""Marching cubes in numpy: the same algorithm, table and output order as the shaders.

Read it beside `shaders/mc_*.comp`; each step below names the pass it mirrors.

Conventions shared with the GPU (see `isoscope.core.case_table` for the cell geometry):

* A sample is *inside* when ``sign * value >= sign * level``, with
  ``sign = +1`` where ``descent`` is true (object above the level: the API's
  gradient_direction "descent") and ``-1`` where it is false ("ascent"); `signed`
  turns field and level so (the *signed* field grows into the object).  Ties
  count as inside: a symbolic form of perturbing exact zeros to a tiny non-zero
  (Bridson, Fluid Simulation for Computer Graphics), so a sample equal to the
  level never needs a special case.
* Every grid edge whose ends differ gets one vertex, owned by the edge's lower
  end, shared by all triangles that use it.  Its parameter along the edge is
  kept within ``[EDGE_MARGIN, 1 - EDGE_MARGIN]`` so that vertices from
  different edges never coincide and no triangle collapses to zero area
  (a tie would otherwise put up to six vertices on one grid point).
* Output order follows the GPU's work split: it packs 32 signs along axis 2
  into a word and groups BRICK_I x BRICK_J rows of words into a brick.
  Vertices are ordered by (brick, word in brick, axis, k); triangles by
  (brick, word in brick, k), then the table's order.  Bricks are numbered
  (i // BRICK_I, j // BRICK_J, k // 32) in C order, words in a brick
  (i % BRICK_I, j % BRICK_J).
"""
from __future__ import annotations

import numpy as np

from ..core.case_table import EDGE_AXIS, EDGE_ORIGIN, CaseTable, montani_table
from ..core.layout import BRICK_I, BRICK_J, EDGE_MARGIN, WORD_BITS


def brick_order_key(points: np.ndarray, shape) -> np.ndarray:
    """The GPU's processing order of the words holding `points` (N, 3): brick first, then word."""
    n0, n1, n2 = shape
    words = -(-n2 // WORD_BITS)
    bricks_j = -(-n1 // BRICK_J)
    i, j, k = points[:, 0], points[:, 1], points[:, 2]
    brick = ((i // BRICK_I) * bricks_j + j // BRICK_J) * words + k // WORD_BITS
    return brick * (BRICK_I * BRICK_J) + (i % BRICK_I) * BRICK_J + j % BRICK_J


def signed(volume: np.ndarray, level: float, descent: bool) -> tuple[np.ndarray, np.float32]:
    """The signed field and level: `volume` and `level` turned so that the object is where the field is at
    or above the level, as they are where `descent` (object above the level), both negated where not.  The
    field is `volume` itself, not a copy, where `descent`; the level is float32."""
    if descent:
        return volume, np.float32(level)
    return -volume, np.float32(-level)


def inside_mask(field: np.ndarray, level: float) -> np.ndarray:
    """mc_signs.comp: True where a sample of the signed field is on the object's side, ties included."""
    return field >= np.float32(level)


def crossing_edges(inside: np.ndarray) -> list[np.ndarray]:
    """mc_classify.comp: per axis, a mask over owning grid points of edges whose ends differ."""
    masks = []
    for axis in range(3):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(0, -1), slice(1, None)
        differ = inside[tuple(lo)] != inside[tuple(hi)]
        pad = [(0, 0)] * 3
        pad[axis] = (0, 1)  # the last grid plane owns no edge along this axis
        masks.append(np.pad(differ, pad))
    return masks


def cube_cases(inside: np.ndarray) -> np.ndarray:
    """mc_classify.comp: the 8-bit case of every cell, bit c set when corner c is inside."""
    n0, n1, n2 = inside.shape
    cases = np.zeros((n0 - 1, n1 - 1, n2 - 1), dtype=np.uint8)
    for corner in range(8):
        d0, d1, d2 = corner & 1, corner >> 1 & 1, corner >> 2 & 1
        bit = inside[d0 : n0 - 1 + d0, d1 : n1 - 1 + d1, d2 : n2 - 1 + d2]
        cases |= bit.astype(np.uint8) << np.uint8(corner)
    return cases


def gradient_at(field: np.ndarray, points: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """Central differences at grid points, one-sided at the border, in physical units."""
    shape = np.array(field.shape)
    grad = np.empty(points.shape, dtype=np.float32)
    for axis in range(3):
        lo, hi = points.copy(), points.copy()
        lo[:, axis] = np.maximum(points[:, axis] - 1, 0)
        hi[:, axis] = np.minimum(points[:, axis] + 1, shape[axis] - 1)
        step = ((hi[:, axis] - lo[:, axis]).astype(np.float32) * np.float32(spacing[axis]))
        diff = field[tuple(hi.T)] - field[tuple(lo.T)]
        grad[:, axis] = diff / step
    return grad


def vertex_positions(field, level, points, axes, spacing, origin=(0, 0, 0), parameters=False, steps=None):
    """mc_vertices.comp's position of each edge's vertex (and with `parameters`, t and the ends' values).

    `field` may be a block of a larger volume whose sample 0 is sample `origin` of the whole:
    positions are then the whole volume's (chunked.py).  `steps` (N, 3) of 0/1 replaces `axes`
    for edges that are not along one axis (the tetrahedra's diagonals, isoscope.cpu.tetra)."""
    step = np.eye(3, dtype=np.int64)[axes] if steps is None else steps
    v0 = field[tuple(points.T)]
    v1 = field[tuple((points + step).T)]
    t = (np.float32(level) - v0) / (v1 - v0)
    t = np.clip(t, EDGE_MARGIN, np.float32(1) - EDGE_MARGIN).astype(np.float32)
    start = (points + np.asarray(origin, np.int64)).astype(np.float32)
    positions = (start + t[:, None] * step.astype(np.float32)) * spacing.astype(np.float32)
    return (positions, t, v0, v1) if parameters else positions


def place_vertices(field, inside, level, points, axes, spacing, descent: bool, steps=None):
    """mc_vertices.comp: position, outward normal and value of each edge's vertex, of the signed field
    (`steps`: as in `vertex_positions`; values are the volume's, turned back where not `descent`)."""
    positions, t, v0, v1 = vertex_positions(field, level, points, axes, spacing, parameters=True, steps=steps)
    step = np.eye(3, dtype=np.int64)[axes] if steps is None else steps
    ends = points + step
    values = (v0 + t * (v1 - v0)) * np.float32(1.0 if descent else -1.0)

    g0 = gradient_at(field, points, spacing)
    g1 = gradient_at(field, ends, spacing)
    grad = g0 + t[:, None] * (g1 - g0)
    length = np.linalg.norm(grad, axis=1)
    normals = np.empty_like(grad)
    ok = length > 0
    normals[ok] = -grad[ok] / length[ok, None]  # the field grows into the object: out is downhill
    # A flat field gives no gradient: point along the edge, from its inside end to its outside end.
    start_inside = inside[tuple(points.T)]
    along = step * spacing.astype(np.float32)
    along /= np.linalg.norm(along, axis=1, keepdims=True)  # exactly `step` for an axis edge
    normals[~ok] = np.where(start_inside[~ok, None], 1.0, -1.0) * along[~ok]
    return positions, normals.astype(np.float32), values.astype(np.float32)


def ordered_edges(masks: list[np.ndarray], shape) -> tuple[np.ndarray, np.ndarray]:
    """The crossing edges (`masks[kind]`: the grid points owning one of that kind; for cubes the kind is
    the axis) as owner points (E, 3) and kinds (E,), in the GPU's (brick, word in brick, kind, k) order."""
    owners = [np.argwhere(m) for m in masks]
    points = np.concatenate(owners).astype(np.int64)
    kinds = np.concatenate([np.full(len(o), kind) for kind, o in enumerate(owners)]).astype(np.int64)
    order = np.lexsort((points[:, 2], kinds, brick_order_key(points, shape)))
    return points[order], kinds[order]


def cell_edge_ids(cells: np.ndarray, edges: np.ndarray, shape) -> np.ndarray:
    """The id (owner point's flat index * 3 + axis) of cell edge `edges` of each cell in `cells` (points,
    broadcast against `edges`): the ids `vertex_of_edges` looks up."""
    owner = cells + EDGE_ORIGIN[edges]
    return np.ravel_multi_index(np.moveaxis(owner, -1, 0), shape) * 3 + EDGE_AXIS[edges]


def vertex_of_edges(edge_ids: np.ndarray, wanted: np.ndarray, table_name: str) -> np.ndarray:
    """The vertex of each `wanted` edge id (M, 3), the vertices being numbered in `edge_ids` order; found
    through the sorted ids: memory in proportion to the mesh, not the volume (a dense map is 24 bytes a
    voxel).  AssertionError where a wanted edge has no vertex: `table_name` is broken."""
    by_id = np.argsort(edge_ids)
    sorted_ids = edge_ids[by_id]
    slot = np.searchsorted(sorted_ids, wanted)
    if wanted.size and not np.array_equal(sorted_ids[np.minimum(slot, len(sorted_ids) - 1)], wanted):
        raise AssertionError(f"a triangle uses an edge with no vertex: the {table_name} is broken")
    return by_id[slot] if wanted.size else np.zeros((0, 3), np.int64)


def ordered_triangles(table: CaseTable, cases: np.ndarray, shape):
    """The passes' triangle order: cells with triangles in (brick, word, k) order, each cell's table
    triangles in order.  Returns the cells (C, 3), each triangle's cell (M,), its table codes (M, 3)."""
    cells = np.argwhere(table.counts[cases] > 0)
    cells = cells[np.lexsort((cells[:, 2], brick_order_key(cells, shape)))]
    cell_cases = cases[tuple(cells.T)]
    n_tri = table.counts[cell_cases].astype(np.int64)
    cell_of_tri = np.repeat(np.arange(len(cells)), n_tri)
    slot = np.arange(n_tri.sum()) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    return cells, cell_of_tri, table.triangles[cell_cases[cell_of_tri], slot].astype(np.int64)


def marching_cubes_reference(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0),
                             descent: bool = True, table: CaseTable | None = None):
    """verts (N,3) float32, faces (M,3) int32, normals (N,3) float32, values (N,) float32.

    `volume` must already be validated (3-D float32, finite, every axis >= 2).
    """
    table = table or montani_table()
    field, lvl = signed(volume, level, descent)
    spacing = np.asarray(spacing, dtype=np.float64)
    inside = inside_mask(field, lvl)

    # Vertices: one per crossing edge, in the GPU's (brick, word, axis, k) order.
    points, axes = ordered_edges(crossing_edges(inside), field.shape)
    verts, normals, values = place_vertices(field, inside, lvl, points, axes, spacing, descent)

    # Triangles: mc_triangles.comp, cells in (brick, word, k) order, the table's triangles in order.
    cells, cell_of_tri, edges = ordered_triangles(table, cube_cases(inside), field.shape)

    # (owner point, axis) -> vertex index.
    wanted = cell_edge_ids(cells[cell_of_tri][:, None, :], edges, field.shape)   # (M, 3 corners)
    faces = vertex_of_edges(np.ravel_multi_index(points.T, field.shape) * 3 + axes, wanted, "case table")
    return verts, faces.astype(np.int32), normals, values
