"""Pass 4's vertices for the compiled CPU extractor (`isoscope.cpu.compiled`): the numpy reference's arithmetic
of a vertex (`cubes.gradient_at`, `cubes.place_vertices`) on float32 samples, bit for bit, and the planes
pass 4 takes it from: per plane of axis 0, the gradient and the signed sample at each sample a crossing edge
ends at (packed: a plane's few kilobytes, not n1 x n2 of them), and scikit-image's cell spreads for its
`values`."""
from __future__ import annotations

import numpy as np

from ..core.layout import EDGE_MARGIN, WORD_BITS
from .jit import _cached_njit, _cut_cells, _low_bits, _lowest_bit, _popcount
from .samples import sample


@_cached_njit(inline="always", error_model="numpy")
def _gradient(flat, swap, grid, sign, i, j, k, spacing):
    """cubes.gradient_at of the signed field at one grid point: central differences, one-sided at the
    border, in physical units (float32 throughout)."""
    n0, n1, n2 = grid[4], grid[5], grid[6]
    lo = max(i - 1, 0)
    hi = min(i + 1, n0 - 1)
    g0 = (sign * sample(flat, swap, grid, hi, j, k)
          - sign * sample(flat, swap, grid, lo, j, k)) / (np.float32(hi - lo) * spacing[0])
    lo = max(j - 1, 0)
    hi = min(j + 1, n1 - 1)
    g1 = (sign * sample(flat, swap, grid, i, hi, k)
          - sign * sample(flat, swap, grid, i, lo, k)) / (np.float32(hi - lo) * spacing[1])
    lo = max(k - 1, 0)
    hi = min(k + 1, n2 - 1)
    g2 = (sign * sample(flat, swap, grid, i, j, hi)
          - sign * sample(flat, swap, grid, i, j, lo)) / (np.float32(hi - lo) * spacing[2])
    return g0, g1, g2


@_cached_njit(inline="always", error_model="numpy")
def _vertex(flat, swap, grid, sign, level, spacing, i, j, k, d0, d1, d2, verts, normals, values, n):
    """cubes.place_vertices for the edge from (i, j, k) to (i + d0, j + d1, k + d2), written at row n."""
    a0, a1, a2 = _gradient(flat, swap, grid, sign, i, j, k, spacing)
    b0, b1, b2 = _gradient(flat, swap, grid, sign, i + d0, j + d1, k + d2, spacing)
    _vertex_between(flat, swap, grid, sign, level, spacing, i, j, k, d0, d1, d2, a0, a1, a2, b0, b1, b2, verts, normals,
                    values, n)


@_cached_njit(inline="always", error_model="numpy")
def _vertex_between(flat, swap, grid, sign, level, spacing, i, j, k, d0, d1, d2, a0, a1, a2, b0, b1, b2, verts, normals,
                    values, n):
    """_vertex with the gradients at the edge's ends given (a at its start, b at its end)."""
    _vertex_of(sign, level, spacing, i, j, k, d0, d1, d2, sign * sample(flat, swap, grid, i, j, k),
               sign * sample(flat, swap, grid, i + d0, j + d1, k + d2), a0, a1, a2, b0, b1, b2, verts, normals, values,
               n)


@_cached_njit(inline="always", error_model="numpy")
def _vertex_of(sign, level, spacing, i, j, k, d0, d1, d2, v0, v1, a0, a1, a2, b0, b1, b2, verts, normals, values, n):
    """_vertex_between with the signed samples at the edge's ends given too (v0 at its start, v1 at its end)."""
    t = (level - v0) / (v1 - v0)
    t = min(max(t, EDGE_MARGIN), np.float32(1) - EDGE_MARGIN)
    zero = np.float32(0)
    verts[n, 0] = (np.float32(i) + (t if d0 else zero)) * spacing[0]
    verts[n, 1] = (np.float32(j) + (t if d1 else zero)) * spacing[1]
    verts[n, 2] = (np.float32(k) + (t if d2 else zero)) * spacing[2]
    values[n] = (v0 + t * (v1 - v0)) * sign
    g0 = a0 + t * (b0 - a0)
    g1 = a1 + t * (b1 - a1)
    g2 = a2 + t * (b2 - a2)
    length = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    if length > 0:
        normals[n, 0] = -g0 / length
        normals[n, 1] = -g1 / length
        normals[n, 2] = -g2 / length
    else:  # a flat field: along the edge, from its inside end to its outside end (in float64, as numpy)
        out = 1.0 if v0 >= level else -1.0
        s0 = np.float64(d0) * np.float64(spacing[0])
        s1 = np.float64(d1) * np.float64(spacing[1])
        s2 = np.float64(d2) * np.float64(spacing[2])
        norm = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        normals[n, 0] = np.float32(out * (s0 / norm))
        normals[n, 1] = np.float32(out * (s1 / norm))
        normals[n, 2] = np.float32(out * (s2 / norm))


@_cached_njit(inline="always", error_model="numpy")
def _plane_gradients(flat, swap, grid, sign, spacing, edges, busy_rows, i, grads, index):
    """The gradient (_gradient) and the signed sample at each sample (i, j, k) a crossing edge ends at (the
    plane's own edges, both ends, and the axis-0 edges of plane i - 1), packed (grads[row] is g0, g1, g2,
    sign * sample: a vertex then reads no sample of its own): index[j, w, 0] holds the samples of word (j, w) that
    have one (a bit mask), index[j, w, 1] the row of grads its first one is in (_gradient_row); the rest
    follow in order.  A plane's few gradients then lie together in a few kilobytes, where a full plane
    (n1 x n2 x 12 bytes, half a megabyte for an MRI) took from the cache the samples the next plane reads
    again.  A row where no edge ends (no busy word in it, the row before it or the plane before it) is passed
    over: nothing reads its index.  Cubes' edges only."""
    n1, nw = edges.shape[1], edges.shape[2]
    row = 0
    for j in range(n1):
        if not (busy_rows[i, j] or (i > 0 and busy_rows[i - 1, j]) or (j > 0 and busy_rows[i, j - 1])):
            continue
        carry = np.int64(0)  # the end of the last word's edge at bit 31 along axis 2
        for w in range(nw):
            e2 = np.int64(edges[i, j, w, 2])
            need = np.int64(edges[i, j, w, 0]) | np.int64(edges[i, j, w, 1]) | e2 | ((e2 << 1) & 0xFFFFFFFF) | carry
            carry = (e2 >> (WORD_BITS - 1)) & 1
            if i > 0:
                need |= np.int64(edges[i - 1, j, w, 0])
            if j > 0:
                need |= np.int64(edges[i, j - 1, w, 1])
            index[j, w, 0] = need
            index[j, w, 1] = row
            k0 = w * WORD_BITS
            while need:
                k = k0 + _lowest_bit(need)
                need &= need - 1
                g0, g1, g2 = _gradient(flat, swap, grid, sign, i, j, k, spacing)
                grads[row, 0] = g0
                grads[row, 1] = g1
                grads[row, 2] = g2
                grads[row, 3] = sign * sample(flat, swap, grid, i, j, k)
                row += 1


@_cached_njit(inline="always", error_model="numpy")
def _gradient_row(index, j, k):
    """The row of a plane's packed gradients (_plane_gradients) that holds sample (j, k)'s."""
    w = k >> 5
    return index[j, w, 1] + _popcount(index[j, w, 0] & _low_bits(k & (WORD_BITS - 1)))


@_cached_njit(inline="always", error_model="numpy")
def _plane_spreads(flat, swap, grid, signs, i, level, out):
    """out[j, k]: scikit-image's spread of cell (i, j, k) for every cell of plane i the level cuts (the only
    cells a vertex's value is taken from: every cell next to a crossing edge is cut).  The arithmetic is
    `isoscope.cpu.skimage_values`': float64 of each float32 sample less the level, the cell's range taken
    with 0, then float32 (which keeps the order of values, so the largest of a vertex's cells is the same)."""
    n0, n1, nw = signs.shape
    n2 = grid[6]
    if i + 1 >= n0:
        return
    for j in range(n1 - 1):
        for w in range(nw):
            k0 = w * WORD_BITS
            cut = _cut_cells(signs, i, j, w, nw, _low_bits(min(WORD_BITS, n2 - 1 - k0)))[0]
            while cut:
                k = k0 + _lowest_bit(cut)
                cut &= cut - 1
                high = 0.0
                low = 0.0
                for c in range(8):
                    v = np.float64(sample(flat, swap, grid, i + (c & 1), j + (c >> 1 & 1), k + (c >> 2))) - level
                    high = max(high, v)
                    low = min(low, v)
                out[j, k] = np.float32(high - low)


@_cached_njit(inline="always", error_model="numpy")
def _edge_spread(grid, i, j, k, axis, before, here):
    """scikit-image's `values` of the vertex on the edge along `axis` from (i, j, k): the largest spread of
    the cells next to the edge, from the planes of cell spreads (_plane_spreads) of planes i - 1 (`before`)
    and i (`here`).  Along the edge's own axis the cell it runs through; along the others (it lies on their
    grid planes) the cells on both sides that the volume has."""
    best = np.float32(0)
    lo1, hi1 = (j, j) if axis == 1 else (max(j - 1, 0), min(j, grid[5] - 2))
    lo2, hi2 = (k, k) if axis == 2 else (max(k - 1, 0), min(k, grid[6] - 2))
    for cj in range(lo1, hi1 + 1):
        for ck in range(lo2, hi2 + 1):
            best = max(best, here[cj, ck]) if axis == 0 or i < grid[4] - 1 else best
            if axis != 0 and i > 0:
                best = max(best, before[cj, ck])
    return best


@_cached_njit(inline="always", error_model="numpy")
def _axis_vertices(flat, swap, grid, sign, level, spacing, edges, i, j, w, n, axis, starts, starts_index, ends,
                   ends_index, end_row, verts, normals, values, spreads, spreads_before, spreads_here):
    """The vertices of word (i, j, w)'s edges along `axis` from row n on, their gradients and samples from the
    planes of gradients (_plane_gradients: `starts` at (j, k), an edge's start, `ends` at (end_row, k or k + 1), its
    end); returns the next row.  With `spreads`, values[n] is scikit-image's (_edge_spread, from the planes of
    cell spreads of planes i - 1 and i), not the level."""
    bits = np.int64(edges[i, j, w, axis])
    d2 = 1 if axis == 2 else 0
    while bits:
        k = w * WORD_BITS + _lowest_bit(bits)
        a = _gradient_row(starts_index, j, k)
        b = _gradient_row(ends_index, end_row, k + d2)
        _vertex_of(sign, level, spacing, i, j, k, 1 if axis == 0 else 0, 1 if axis == 1 else 0, d2, starts[a, 3],
                   ends[b, 3], starts[a, 0], starts[a, 1], starts[a, 2], ends[b, 0], ends[b, 1], ends[b, 2], verts,
                   normals, values, n)
        if spreads:
            values[n] = _edge_spread(grid, i, j, k, axis, spreads_before, spreads_here)
        bits &= bits - 1
        n += 1
    return n
