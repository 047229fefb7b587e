"""topology="trilinear" compiled for the CPU (numba): `isoscope.cpu.trilinear`'s mesh, bit for bit.

The cubes' passes (compiled.py) pack the signs, find the crossing edges and write their vertices as for
today's mesh (the same edges, the same vertices).  Two passes of this module replace the triangles':

* `_count`  per word: the table key of each cut cell (its case, and where the case is ambiguous the faces'
            and the interior's decisions from its eight samples, `_cell_key`), the key's triangles and own
            vertices counted; the counts are scanned in the words' order as the others.
* `_write`  per word, after every edge vertex is written: each cut cell's triangles at its offset, and its
            own vertices (the mean of listed edge vertices) after all the edge vertices.

The decisions are the reference's float64 arithmetic in its order (numba contracts no multiply-add), so
the keys, and so the faces, are the reference's.
"""
from __future__ import annotations

from functools import cache

import numpy as np
from numba import prange

from ..core.case_table import FACE_CORNERS
from ..core.layout import WORD_BITS
from ..core.trilinear_table import FIRST_CELL_VERTEX, case_masks, trilinear_table
from .compiled import EDGE_ROW, CompiledCubes, _cube_rows, _edge_vertex, _write_cubes
from .jit import _cached_njit, _case, _cut_cells, _low_bits, _lowest_bit
from .samples import sample
from .words import _scan

_FACE_CORNERS = np.array(FACE_CORNERS, np.int64)
_EDGE_CODES = (EDGE_ROW[:, 0] * 2 + EDGE_ROW[:, 1]).astype(np.int64)


@_cached_njit(inline="always", error_model="numpy")
def _cell_key(flat, swap, grid, sign, level, i, j, k, case, ambiguous, needs, face_corners, d):
    """trilinear.trilinear_keys for one cell (`d`: 8 float64 of scratch)."""
    if not needs[case]:
        return case
    for c in range(8):
        d[c] = np.float64(sign * sample(flat, swap, grid, i + (c & 1), j + (c >> 1 & 1), k + (c >> 2))) - level
    faces = 0
    for f in range(6):
        if ambiguous[case] >> f & 1:
            first = d[face_corners[f, 0]] * d[face_corners[f, 2]]
            second = d[face_corners[f, 1]] * d[face_corners[f, 3]]
            joins = first >= second if d[face_corners[f, 0]] >= 0 else second >= first
            if joins:
                faces |= 1 << f
    r0, r1, r2, r3 = d[4] - d[0], d[5] - d[1], d[6] - d[2], d[7] - d[3]
    a = r0 * r3 - r1 * r2
    b = (d[0] * r3 + d[3] * r0) - (d[1] * r2 + d[2] * r1)
    c = d[0] * d[3] - d[1] * d[2]
    tunnel = 0
    if a != 0 and ((b > 0 and b < -2 * a) if a < 0 else (b < 0 and b > -2 * a)):
        sign_a = 1.0 if a > 0 else -1.0
        in0 = (2 * a * d[0] - b * r0) * sign_a >= 0
        in1 = (2 * a * d[1] - b * r1) * sign_a >= 0
        in2 = (2 * a * d[2] - b * r2) * sign_a >= 0
        in3 = (2 * a * d[3] - b * r3) * sign_a >= 0
        saddle = (4 * a * c - b * b) * sign_a
        if in0 and in3 and not in1 and not in2:
            tunnel = 1 if saddle >= 0 else 4
        elif in1 and in2 and not in0 and not in3:
            tunnel = 2 if saddle <= 0 else 3
    return case | faces << 8 | tunnel << 14


@_cached_njit(parallel=True, error_model="numpy")
def _count(flat, swap, layout, sign, level, signs, counts, own, ambiguous, needs, face_corners, triangle_counts,
           own_counts):
    """Per word: its cut cells' triangles and own vertices under their keys."""
    n0, n1, nw = signs.shape
    n2 = layout[6]
    for i in prange(n0):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])
        d = np.empty(8, np.float64)
        for j in range(n1):
            for w in range(nw):
                triangles = 0
                vertices = 0
                if i + 1 < n0 and j + 1 < n1:
                    k0 = w * WORD_BITS
                    cut, a, b, c, e, a1, b1, c1, e1 = _cut_cells(signs, i, j, w, nw, _low_bits(min(WORD_BITS,
                                                                                                  n2 - 1 - k0)))
                    while cut:
                        bit = _lowest_bit(cut)
                        cut &= cut - 1
                        key = _cell_key(flat, swap, grid, sign, level, i, j, k0 + bit,
                                        _case(bit, a, b, c, e, a1, b1, c1, e1), ambiguous, needs, face_corners, d)
                        triangles += counts[key]
                        vertices += own[key]
                triangle_counts[i, j, w] = triangles
                own_counts[i, j, w] = vertices


@_cached_njit(parallel=True, error_model="numpy")
def _write(flat, swap, layout, sign, level, signs, edges, vertex_offsets, triangle_offsets, own_offsets, own_base,
           counts, codes, own, own_masks, edge_codes, ambiguous, needs, face_corners, row_owner, verts, faces, normals,
           values):
    """Per word: its cut cells' triangles, and their own vertices from the edge vertices written before."""
    n0, n1, nw = signs.shape
    n2 = layout[6]
    for i in prange(n0 - 1):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])
        d = np.empty(8, np.float64)
        masks = np.empty(row_owner.shape[0], np.int64)
        firsts = np.empty(row_owner.shape[0], np.int64)
        for j in range(n1 - 1):
            for w in range(nw):
                k0 = w * WORD_BITS
                cut, a, b, c, e, a1, b1, c1, e1 = _cut_cells(signs, i, j, w, nw, _low_bits(min(WORD_BITS, n2 - 1 - k0)))
                if cut == 0:
                    continue
                _cube_rows(edges, vertex_offsets, i, j, w, masks, firsts)
                m = triangle_offsets[i, j, w]
                o = own_base + own_offsets[i, j, w]
                while cut:
                    bit = _lowest_bit(cut)
                    cut &= cut - 1
                    key = _cell_key(flat, swap, grid, sign, level, i, j, k0 + bit,
                                    _case(bit, a, b, c, e, a1, b1, c1, e1), ambiguous, needs, face_corners, d)
                    for slot in range(counts[key]):
                        for corner in range(3):
                            code = codes[key, slot, corner]
                            if code < FIRST_CELL_VERTEX:
                                faces[m, corner] = _edge_vertex(edge_codes[code], bit, masks, firsts, edges,
                                                                vertex_offsets, row_owner, i, j, k0)
                            else:
                                faces[m, corner] = o + code - FIRST_CELL_VERTEX
                        m += 1
                    for slot in range(own[key]):
                        _own_vertex(own_masks[key, slot], bit, masks, firsts, edges, vertex_offsets, row_owner, i, j,
                                    k0, edge_codes, verts, normals, values, o)
                        o += 1


@_cached_njit(inline="always", error_model="numpy")
def _own_vertex(mask, bit, masks, firsts, edges, vertex_offsets, row_owner, i, j, k0, edge_codes, verts, normals,
                values, o):
    """A cell's own vertex at row o: the mean of its edges' vertices (trilinear.py's float32 arithmetic)."""
    zero = np.float32(0)
    p0 = p1 = p2 = n0 = n1 = n2 = value = zero
    count = 0
    for e in range(12):
        if mask >> e & 1:
            v = _edge_vertex(edge_codes[e], bit, masks, firsts, edges, vertex_offsets, row_owner, i, j, k0)
            p0 = p0 + verts[v, 0]
            p1 = p1 + verts[v, 1]
            p2 = p2 + verts[v, 2]
            n0 = n0 + normals[v, 0]
            n1 = n1 + normals[v, 1]
            n2 = n2 + normals[v, 2]
            value = value + values[v]
            count += 1
    many = np.float32(count)
    verts[o, 0] = p0 / many
    verts[o, 1] = p1 / many
    verts[o, 2] = p2 / many
    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if length > 0:
        n0, n1, n2 = n0 / length, n1 / length, n2 / length
    normals[o, 0] = n0
    normals[o, 1] = n1
    normals[o, 2] = n2
    values[o] = value / many


@cache
def _kernel_tables():
    """The table as the kernels read it, made once per process: per key its triangle count, triangle codes
    (int8), own-vertex count and own vertices' edge masks; per case its ambiguous faces and whether any
    decision can change its triangles (`case_masks`)."""
    table = trilinear_table()
    own_masks = table.cell_vertices.astype(np.int64)
    return (table.counts.astype(np.int64), table.triangles, (own_masks > 0).sum(axis=1).astype(np.int64), own_masks,
            *case_masks())


class CompiledTrilinear(CompiledCubes):
    """`CompiledCubes` whose triangles have the trilinear interpolant's topology (`trilinear.py`)."""

    recounts = False  # its own pass counts the triangles, in the offsets' arrays, at every level

    def __init__(self, volume, spacing, descent: bool, reuse_outputs: bool = False, value_range=None):
        super().__init__(volume, spacing, descent, reuse_outputs=reuse_outputs, value_range=value_range)
        (self._keys_counts, self._codes, self._own, self._own_masks, self._ambiguous,
         self._needs) = _kernel_tables()
        self._own_offsets = np.empty_like(self._vertex_offsets)
        self._own_scratch = np.zeros_like(self._vertex_offsets)

    def _write_mesh(self, level, user_level: float, workers: int, skimage_values: bool):
        flat, swap, grid = self.view.flat, self.view.swap, self.view.grid
        level64 = np.float64(level)
        _count(flat, swap, grid, self.sign, level64, self._signs, self._keys_counts, self._own, self._ambiguous,
               self._needs, _FACE_CORNERS, self._triangle_offsets, self._own_offsets)
        n_edge_vertices, n_triangles = _scan(self._vertex_offsets, self._triangle_offsets, self._vertex_offsets,
                                             self._triangle_offsets)  # pass 2's vertex counts, its own triangles'
        self._own_scratch[:] = 0
        n_own, _ = _scan(self._own_offsets, self._own_scratch, self._own_offsets, self._own_scratch)
        self._check_size(n_edge_vertices + n_own, n_triangles, user_level)
        verts, faces, normals, values = self._output_arrays(n_edge_vertices + n_own, n_triangles)
        _write_cubes(flat, swap, grid, self.sign, level, self.spacing, self._signs, self._edges, self._vertex_offsets,
                     self._triangle_offsets, self._busy, self._busy_rows, self._counts, self._corners, self._row_owner,
                     workers, self._runs(workers), self._taken, self._plane_rows(), verts, faces, normals, values,
                     False, user_level, False)
        _write(flat, swap, grid, self.sign, level64, self._signs, self._edges, self._vertex_offsets,
               self._triangle_offsets, self._own_offsets, n_edge_vertices, self._keys_counts, self._codes, self._own,
               self._own_masks, _EDGE_CODES, self._ambiguous, self._needs, _FACE_CORNERS, self._row_owner, verts,
               faces, normals, values)
        return verts, faces, normals, values


def marching_cubes_trilinear_compiled(volume, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True):
    """`trilinear.marching_cubes_trilinear`'s mesh from the compiled kernels."""
    return CompiledTrilinear(volume, spacing, descent).extract(level)


__all__ = ["CompiledTrilinear", "marching_cubes_trilinear_compiled"]
