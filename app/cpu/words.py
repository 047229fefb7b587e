"""Passes 1 to 3 of the compiled CPU extractor (`isoscope.cpu.compiled`): the volume's inside bits packed 32
to a word along axis 2, each word's crossing edges and counts, and their prefix sums.

The samples are read where they lie (`isoscope.cpu.samples`): a volume whose axis 2 is contiguous (C order)
a row of 32 samples a word, one whose axis 0 is (Fortran order: nibabel's) in blocks of rows of axis 0,
each row setting one bit of n0 words; every such row is a slice LLVM vectorizes.  A volume nothing has
scanned before has its value range measured in the same reads (`measure`).
"""
from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import prange, types
from numba.extending import intrinsic, overload

from ..core.layout import BRICK_I, BRICK_J, WORD_BITS
from .jit import _cached_njit, _case, _cut_cells, _low_bits, _lowest_bit, _popcount, _shifted, _take
from .samples import ORDER_F, raw, sample

# Pass 4's time per word, vertex and triangle, roughly (in 2 ns on one core here): how planes are split in runs.
WORK_WORD, WORK_VERTEX, WORK_TRIANGLE = 1, 16, 4


@_cached_njit(parallel=True, error_model="numpy")
def _word_ranges(flat, swap, layout, order, lows, highs):
    """The smallest and largest sample (as float32) of each word (its 32 samples along axis 2 and the next
    one, the far end of its last edge).  A volume whose axis 0 is contiguous (ORDER_F) is read a row of
    axis 0 at a time, each row updating the ranges of n0 words at once."""
    off, s1, s2 = layout[0], layout[2], layout[3]
    n0, n1, n2 = layout[4], layout[5], layout[6]
    nw = lows.shape[2]
    if order == ORDER_F:
        for j in prange(n1):
            lo = np.empty(n0, np.float32)
            hi = np.empty(n0, np.float32)
            for w in range(nw):
                k0 = w * WORD_BITS
                k1 = min(k0 + WORD_BITS + 1, n2)
                for k in range(k0, k1):
                    start = off + j * s1 + k * s2
                    for i in range(n0):
                        v = np.float32(raw(flat, swap, start + i))
                        lo[i] = v if k == k0 else min(lo[i], v)
                        hi[i] = v if k == k0 else max(hi[i], v)
                for i in range(n0):
                    lows[i, j, w] = lo[i]
                    highs[i, j, w] = hi[i]
        return
    for i in prange(n0):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])  # a tuple in the
        # loop's body (numba's parallel loops capture no tuples): its numbers stay in registers
        for j in range(n1):
            for w in range(nw):
                k0 = w * WORD_BITS
                k1 = min(k0 + WORD_BITS + 1, n2)
                lo = sample(flat, swap, grid, i, j, k0)
                hi = lo
                for k in range(k0 + 1, k1):
                    v = sample(flat, swap, grid, i, j, k)
                    lo = min(lo, v)
                    hi = max(hi, v)
                lows[i, j, w] = lo
                highs[i, j, w] = hi


@_cached_njit(inline="always", error_model="numpy")
def _range_outside(sign, level, low, high):
    """With samples' range (low, high) known: -1 where the level does not cut them and every one is inside,
    0 where every one is outside, 1 where they must be read."""
    lo = sign * low
    hi = sign * high
    if hi < lo:
        lo, hi = hi, lo
    if lo >= level:
        return -1
    if hi < level:
        return 0
    return 1


@_cached_njit(inline="always", error_model="numpy")
def _word_outside(sign, level, lows, highs, i, j, w, count):
    """_range_outside of word (i, j, w) (every sample inside: the word is all ones)."""
    return _range_outside(sign, level, lows[i, j, w], highs[i, j, w])


def _extent(values, lo, hi, nan):
    """lo, hi and nan (a NaN seen) taken over `values` too (compiled only: the loop is made by type below)."""
    raise NotImplementedError("compiled only")


@overload(_extent, inline="always")
def _extent_of(values, lo, hi, nan):
    """Integers: min and max, a loop LLVM vectorizes.  Floats: LLVM vectorizes no float min or max (their NaN
    rules), so a float's bits stand in for it, as an int64 that orders as the floats do (_order_key), and a
    NaN is found by its bits; an infinite sample comes out as an infinite bound.  Three times faster on a
    float32 row here."""
    if not isinstance(values.dtype, types.Float):
        def integers(values, lo, hi, nan):
            for x in range(values.shape[0]):
                v = values[x]
                lo = min(lo, v)
                hi = max(hi, v)
            return lo, hi, nan
        return integers
    single = values.dtype.bitwidth == 32
    bits = np.int32 if single else np.int64
    magnitude = np.int64(0x7FFFFFFF if single else 0x7FFFFFFFFFFFFFFF)   # every bit but the sign
    infinity = np.int64(0x7F800000 if single else 0x7FF0000000000000)    # a larger magnitude is a NaN

    def floats(values, lo, hi, nan):
        words = values.view(bits)
        low = _order_key(_bits_of(lo), magnitude)
        high = _order_key(_bits_of(hi), magnitude)
        found = False
        for x in range(words.shape[0]):
            word = np.int64(words[x])
            key = _order_key(word, magnitude)
            low = min(low, key)
            high = max(high, key)
            found |= (word & magnitude) > infinity
        return _float_of(_order_key(low, magnitude), lo), _float_of(_order_key(high, magnitude), hi), nan | found
    return floats


@_cached_njit(inline="always", error_model="numpy")
def _order_key(word, magnitude):
    """An IEEE float's bits (sign-extended to int64) as an int64 that orders as the floats do: a negative
    float's magnitude bits flipped.  Its own inverse."""
    return word ^ ((word >> 63) & magnitude)


@intrinsic
def _bits_of(typingctx, value):
    """A float32's or float64's bits as an int64 (sign-extended)."""
    width = value.bitwidth

    def codegen(context, builder, signature, args):
        return builder.sext(builder.bitcast(args[0], ir.IntType(width)), ir.IntType(64))
    return types.int64(value), codegen


@intrinsic
def _float_of(typingctx, word, like):
    """The float of `like`'s type whose bits are the low bits of the int64 `word`."""
    def codegen(context, builder, signature, args):
        kind = context.get_value_type(like)
        return builder.bitcast(builder.trunc(args[0], ir.IntType(like.bitwidth)), kind)
    return like(word, like), codegen


@_cached_njit(error_model="numpy")
def _pack_plane(flat, swap, grid, sign, level, lows, highs, ranged, signs, i, measure, los, his, nans, previous,
                changed, compare):
    """Pass 1 on plane i: bit k of signs[i, j, w] is set where sample (i, j, 32 w + k) of the signed field
    (sign * field) is at or above `level`.  With `ranged`, lows/highs (the words' ranges of `field`)
    let a word the level does not cut be filled without reading its samples.  With `measure`, the plane's
    smallest and largest sample (in their own type) go to los[i] and his[i], and whether one is NaN to
    nans[i]: the value range of a volume nothing scanned before, read in the same pass.  With `compare`,
    bit w of changed[i, j, 0] is set where word (i, j, w) differs from previous[i, j, w] (the last level's
    words), of changed[i, j, 1] where its first bit does: pass 2 then recounts only the words next to a
    change (_count_plane)."""
    off, s0, s1, s2 = grid[0], grid[1], grid[2], grid[3]
    n1, n2 = grid[5], grid[6]
    nw = signs.shape[2]
    contiguous = s2 == 1 and not swap
    lo = raw(flat, swap, off + i * s0)
    hi = lo
    nan = False
    for j in range(n1):
        row = off + i * s0 + j * s1
        if measure and contiguous:
            lo, hi, nan = _extent(flat[row:row + n2], lo, hi, nan)
        moved = np.int64(0)
        first = np.int64(0)
        for w in range(nw):
            k0 = w * WORD_BITS
            count = min(WORD_BITS, n2 - k0)
            outside = _word_outside(sign, level, lows, highs, i, j, w, count) if ranged else 1
            word = np.int64(0)
            if outside < 0:
                word = _low_bits(count)
            elif outside > 0:
                start = row + k0 * s2
                if contiguous:  # on a slice of the row, which LLVM vectorizes
                    samples = flat[start:start + count]
                    for b in range(count):
                        word |= np.int64(sign * np.float32(samples[b]) >= level) << b
                else:
                    for b in range(count):
                        v = raw(flat, swap, start + b * s2)
                        word |= np.int64(sign * np.float32(v) >= level) << b
                        if measure:
                            lo = min(lo, v)
                            hi = max(hi, v)
                            nan |= v != v
            signs[i, j, w] = word
            if compare:
                diff = word ^ np.int64(previous[i, j, w])
                moved |= np.int64(diff != 0) << w
                first |= (diff & 1) << w
        if compare:  # one store each: the run before this plane's may pack it too, to the same words and bits
            changed[i, j, 0] = moved
            changed[i, j, 1] = first
    if measure:
        los[i] = lo
        his[i] = hi
        nans[i] = nan


BLOCK_BYTES = 1 << 20
"""_pack_rows_along_0 gathers the words of a block of rows of axis 1 (at most 32 rows, at most this many bytes
of words: a core's L2 cache) before it stores them to signs plane by plane, 32 x nw words in a row, not one
word per cache line; the rows of a block lie one after another in the volume's memory."""


def rows_per_block(shape) -> int:
    """How many rows of axis 1 are packed into words at once: up to 32, as many as keep a block's words within
    `BLOCK_BYTES` (a core's L2 cache)."""
    n0, _, n2 = shape
    return int(max(1, min(32, BLOCK_BYTES // (4 * n0 * -(-n2 // WORD_BITS)))))


@_cached_njit(parallel=True, error_model="numpy")
def _pack_rows_along_0(flat, swap, grid, sign, level, lows, highs, ranged, signs, block_rows, measure, los,
                       his, nans, previous, changed, compare):
    """Pass 1 for a volume whose axis 0 is contiguous (ORDER_F, nibabel's arrays): _pack_plane's words, read
    in memory order.  Per row (j, w) of words, bit b of all n0 words is set from the contiguous row of
    samples (:, j, 32 w + b), a slice LLVM vectorizes.  With `ranged` (lows and highs in Fortran order), a row
    of words none of which the level cuts is filled without reading its samples; a row the level cuts is
    read whole (its words' ranges, one by one, cost more than the vectorized reads they would save).  Rows
    of axis 1 go in blocks of `block_rows` (rows_per_block) to the threads.  With `measure`, _pack_plane's
    extent of each block's samples goes to los, his and nans[block].  `previous`, `changed`, `compare`: as for
    _pack_plane."""
    off, s1, s2 = grid[0], grid[2], grid[3]
    n0, n1, n2 = grid[4], grid[5], grid[6]
    nw = signs.shape[2]
    blocks = -(-n1 // block_rows)
    for block in prange(blocks):
        j0 = block * block_rows
        rows = min(block_rows, n1 - j0)
        bits = np.empty((rows, nw, n0), np.uint32)
        read = np.empty(rows, np.bool_)
        lo = raw(flat, swap, off + j0 * s1)
        hi = lo
        nan = False
        for w in range(nw):
            k0 = w * WORD_BITS
            count = min(WORD_BITS, n2 - k0)
            for r in range(rows):
                outside = 1
                if ranged:  # the row's range: the smallest low and largest high of its words
                    row_low = lows[0, j0 + r, w]
                    row_high = highs[0, j0 + r, w]
                    for i in range(1, n0):
                        row_low = min(row_low, lows[i, j0 + r, w])
                        row_high = max(row_high, highs[i, j0 + r, w])
                    outside = _range_outside(sign, level, row_low, row_high)
                bits[r, w, :] = np.uint32(_low_bits(count)) if outside < 0 else np.uint32(0)
                read[r] = outside > 0
            for b in range(count):  # the block's rows of sample 32 w + b lie one after another in memory
                shift = np.uint32(b)
                for r in range(rows):
                    if not read[r]:
                        continue
                    start = off + (j0 + r) * s1 + (k0 + b) * s2
                    words = bits[r, w]
                    if not swap:  # on a slice of the row, which LLVM vectorizes
                        row = flat[start:start + n0]
                        for i in range(n0):
                            words[i] |= np.uint32(sign * np.float32(row[i]) >= level) << shift
                        if measure:
                            lo, hi, nan = _extent(row, lo, hi, nan)
                    else:
                        for i in range(n0):
                            v = raw(flat, swap, start + i)
                            words[i] |= np.uint32(sign * np.float32(v) >= level) << shift
                            if measure:
                                lo = min(lo, v)
                                hi = max(hi, v)
                                nan |= v != v
        for i in range(n0):
            for r in range(rows):
                moved = np.int64(0)
                first = np.int64(0)
                for w in range(nw):
                    word = bits[r, w, i]
                    signs[i, j0 + r, w] = word
                    if compare:
                        diff = np.int64(word ^ previous[i, j0 + r, w])
                        moved |= np.int64(diff != 0) << w
                        first |= (diff & 1) << w
                if compare:
                    changed[i, j0 + r, 0] = moved
                    changed[i, j0 + r, 1] = first
        if measure:
            los[block] = lo
            his[block] = hi
            nans[block] = nan


@_cached_njit(inline="always", error_model="numpy")
def _uniform(signs, i, j, w, s, full):
    """Whether word (i, j, w) (its bits s, `full` those of a word all inside) and the words after it along
    axes 0 and 1 and both are all inside or all outside, and so is the first sample of the next word of
    each: no edge, no cut cell (most of a volume's words; pass 2 then writes zeros and goes on).  False on
    the last plane and row (their words' neighbours are missing)."""
    n0, n1, nw = signs.shape
    if i + 1 >= n0 or j + 1 >= n1 or (s != 0 and s != full):
        return False
    if np.int64(signs[i + 1, j, w]) != s or np.int64(signs[i, j + 1, w]) != s or np.int64(signs[i + 1, j + 1, w]) != s:
        return False
    if w + 1 == nw:
        return True
    bit = s & 1
    return ((np.int64(signs[i, j, w + 1]) & 1) == bit and (np.int64(signs[i + 1, j, w + 1]) & 1) == bit
            and (np.int64(signs[i, j + 1, w + 1]) & 1) == bit and (np.int64(signs[i + 1, j + 1, w + 1]) & 1) == bit)


@_cached_njit(inline="always", error_model="numpy")
def _near_changes(changed, i, j):
    """The words of row (i, j) whose counts a change of pass 1 reaches (a bit per word): those with a change in
    rows (i, j), (i + 1, j), (i, j + 1) or (i + 1, j + 1) at the same word, or at the first bit of the next."""
    n0, n1 = changed.shape[0], changed.shape[1]
    near = changed[i, j, 0]
    first = changed[i, j, 1]
    if i + 1 < n0:
        near |= changed[i + 1, j, 0]
        first |= changed[i + 1, j, 1]
    if j + 1 < n1:
        near |= changed[i, j + 1, 0]
        first |= changed[i, j + 1, 1]
        if i + 1 < n0:
            near |= changed[i + 1, j + 1, 0]
            first |= changed[i + 1, j + 1, 1]
    return near | (first >> 1)


@_cached_njit(error_model="numpy")
def _count_plane(signs, n2, steps, table_counts, edges, vertex_counts, triangle_counts, busy, busy_rows, plane_work,
                 i, changed, recount):
    """Pass 2 on plane i: per word, the crossing-edge masks (edges[i, j, w, kind]: the edges from its samples
    to the samples steps[kind] away), its vertex count and triangle count, whether it has either (busy: pass 4
    passes over the others, most of a volume's words) and whether a row has a busy word (busy_rows[i, j]: pass 4
    passes over the other rows at once); an estimate of pass 4's time on the plane (WORK_* units) and its
    vertices and triangles (plane_work[i]: pass 3 starts a slab of planes from them).  Three steps
    must be the axes in order (CUBE_STEPS).  With `recount`, the arrays hold the last level's counts and only
    the words whose cells or edges reach a word pass 1 changed (`changed`: per row, a bit per word changed and
    a bit per word whose first bit did) are counted again: a word's counts depend on its own bits, those of the
    words after it along axes 0 and 1 and both, and the first bits of the next words along axis 2."""
    n0, n1, nw = signs.shape
    axes_only = steps.shape[0] == 3
    work = plane_work[i, 0] if recount else n1 * nw * WORK_WORD
    plane_vertices = plane_work[i, 1] if recount else 0
    plane_triangles = plane_work[i, 2] if recount else 0
    near = np.int64(-1)  # the words to count in a row: all of them, unless recounting
    for j in range(n1):
        if recount:
            near = _near_changes(changed, i, j)
            if near == 0:
                continue
        for w in range(nw):
            if recount:  # a word next to no change keeps its counts; one that is counted loses its old share
                if not (near >> w) & 1:
                    continue
                old_vertices, old_triangles = vertex_counts[i, j, w], triangle_counts[i, j, w]
                work -= old_vertices * WORK_VERTEX + old_triangles * WORK_TRIANGLE
                plane_vertices -= old_vertices
                plane_triangles -= old_triangles
            k0 = w * WORD_BITS
            s = np.int64(signs[i, j, w])
            # Edges with a step along axis 2 end in the row: the last sample owns none.
            along2 = _low_bits(min(WORD_BITS, n2 - 1 - k0))
            if axes_only and _uniform(signs, i, j, w, s, _low_bits(min(WORD_BITS, n2 - k0))):
                edges[i, j, w, 0] = 0
                edges[i, j, w, 1] = 0
                edges[i, j, w, 2] = 0
                vertex_counts[i, j, w] = 0
                triangle_counts[i, j, w] = 0
                busy[i, j, w] = False
                continue
            if axes_only:  # cubes (steps the three axes, in order): unrolled, 40% of this pass's time
                e0 = s ^ np.int64(signs[i + 1, j, w]) if i + 1 < n0 else 0
                e1 = s ^ np.int64(signs[i, j + 1, w]) if j + 1 < n1 else 0
                e2 = (s ^ _shifted(signs, i, j, w, nw)) & along2
                edges[i, j, w, 0] = e0
                edges[i, j, w, 1] = e1
                edges[i, j, w, 2] = e2
                vertices = _popcount(e0) + _popcount(e1) + _popcount(e2)
            else:
                vertices = 0
                for kind in range(steps.shape[0]):
                    oi = i + steps[kind, 0]
                    oj = j + steps[kind, 1]
                    e = 0
                    if oi < n0 and oj < n1:
                        if steps[kind, 2]:
                            e = (s ^ _shifted(signs, oi, oj, w, nw)) & along2
                        else:
                            e = s ^ np.int64(signs[oi, oj, w])
                    edges[i, j, w, kind] = e
                    vertices += _popcount(e)
            vertex_counts[i, j, w] = vertices
            triangles = 0
            if i + 1 < n0 and j + 1 < n1:
                cut, a, b, c, d, a1, b1, c1, d1 = _cut_cells(signs, i, j, w, nw, along2)
                while cut:
                    k = _lowest_bit(cut)
                    cut &= cut - 1
                    triangles += table_counts[_case(k, a, b, c, d, a1, b1, c1, d1)]
            triangle_counts[i, j, w] = triangles
            busy[i, j, w] = vertices + triangles > 0
            work += vertices * WORK_VERTEX + triangles * WORK_TRIANGLE
            plane_vertices += vertices
            plane_triangles += triangles
        row = False
        for w in range(nw):
            row |= busy[i, j, w]
        busy_rows[i, j] = row
    plane_work[i, 0] = work
    plane_work[i, 1] = plane_vertices
    plane_work[i, 2] = plane_triangles


@_cached_njit(parallel=True, error_model="numpy")
def _pack_and_count(flat, swap, layout, pack, sign, level, lows, highs, ranged, signs, steps, table_counts, edges,
                    vertex_counts, triangle_counts, busy, busy_rows, plane_work, workers, starts, taken, measure, los,
                    his, nans, previous, changed, recount):
    """Passes 1 and 2 in one launch (one wait for the threads, not two), over runs of planes (starts[r] to
    starts[r + 1]) taken in turn by `workers` threads (taken[0], reset to 0 by the caller): a run packs its
    planes and the plane after it, then counts its planes.  That next plane's words are packed twice, by
    this run and the next, to the same values.  With `pack` False the words are packed already
    (_pack_rows_along_0): pass 2 alone.  `measure`, los, his, nans: as for _pack_plane.  With `recount`,
    pass 1 compares each word with `previous` (the last level's words, another array) and pass 2 counts
    again only the words next to a change (_count_plane)."""
    n0, n2 = layout[4], layout[6]
    for _worker in prange(workers):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])  # a tuple in the
        # loop's body (numba's parallel loops capture no tuples): its numbers stay in registers
        while True:
            run = _take(taken)
            if run >= starts.shape[0] - 1:
                break
            if pack:
                for i in range(starts[run], min(starts[run + 1] + 1, n0)):
                    _pack_plane(flat, swap, grid, sign, level, lows, highs, ranged, signs, i, measure, los, his, nans,
                                previous, changed, recount)
            for i in range(starts[run], starts[run + 1]):
                _count_plane(signs, n2, steps, table_counts, edges, vertex_counts, triangle_counts, busy, busy_rows,
                             plane_work, i, changed, recount)


@_cached_njit(inline="always", error_model="numpy")
def _scan_slab(vertex_counts, triangle_counts, vertex_offsets, triangle_offsets, busy, bi, vertices, triangles):
    """_scan's prefix sums over the bricks of planes bi to bi + BRICK_I (a slab), from the vertices and
    triangles of the slabs before it; returns those after it."""
    n0, n1, nw = vertex_counts.shape
    for bj in range(0, n1, BRICK_J):
        for w in range(nw):
            for i in range(bi, min(bi + BRICK_I, n0)):
                for j in range(bj, min(bj + BRICK_J, n1)):
                    if busy is not None and not busy[i, j, w]:
                        continue
                    v = vertex_counts[i, j, w]
                    t = triangle_counts[i, j, w]
                    vertex_offsets[i, j, w] = vertices
                    triangle_offsets[i, j, w] = triangles
                    vertices += v
                    triangles += t
    return vertices, triangles


@_cached_njit(error_model="numpy")
def _scan(vertex_counts, triangle_counts, vertex_offsets, triangle_offsets, busy=None):
    """Pass 3: the exclusive prefix sums of the counts in the GPU's word order (brick (i // BRICK_I,
    j // BRICK_J, w) in C order, then (i % BRICK_I, j % BRICK_J)) into the offsets (which may be the counts'
    own arrays); returns the totals.  Given `busy` (pass 2's), only busy words get their offsets: the others
    count nothing, and pass 4 reads no offset of theirs (a word is busy where it has an edge)."""
    vertices = 0
    triangles = 0
    for bi in range(0, vertex_counts.shape[0], BRICK_I):
        vertices, triangles = _scan_slab(vertex_counts, triangle_counts, vertex_offsets, triangle_offsets, busy, bi,
                                         vertices, triangles)
    return vertices, triangles


@_cached_njit(parallel=True, error_model="numpy")
def _scan_slabs(vertex_counts, triangle_counts, vertex_offsets, triangle_offsets, busy, plane_work, workers, taken):
    """_scan (busy words only) with the slabs of BRICK_I planes taken in turn by `workers` threads (taken[0], reset
    to 0 by the caller), each slab starting from the vertices and triangles of the planes before it (pass 2's
    plane_work[:, 1:]).  The totals are plane_work's sums."""
    n0 = vertex_counts.shape[0]
    slabs = -(-n0 // BRICK_I)
    for _worker in prange(workers):
        while True:
            slab = _take(taken)
            if slab >= slabs:
                break
            vertices = 0
            triangles = 0
            for i in range(slab * BRICK_I):
                vertices += plane_work[i, 1]
                triangles += plane_work[i, 2]
            _scan_slab(vertex_counts, triangle_counts, vertex_offsets, triangle_offsets, busy, slab * BRICK_I, vertices,
                       triangles)
