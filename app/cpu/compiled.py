"""Marching cubes and tetrahedra compiled for the CPU (numba): the numpy references' meshes
(`isoscope.cpu.cubes`, `isoscope.cpu.tetra`), bit for bit, fast.

The design is the GPU's (shaders/mc_*.comp) and Flying Edges' (Schroeder, Maynard, Geveci 2015): the
samples are read once, to pack their inside bits 32 to a word along axis 2; everything after works on
those words with bit operations, and only the cells the surface cuts do per-cell work.

1. `_pack_plane`   per word (a row of 32 samples along axis 2): its inside bits.  A word whose sample
                   range (measured once per volume, `_word_ranges`) lies wholly on one side of the
                   level is filled without reading a sample: an iso change touches only the words the
                   level cuts.
2. `_count_plane`  per word: the crossing edges it owns, one bit mask per axis (the XOR of a word and
                   its neighbour along the axis), and the triangles of its cut cells (the case table's
                   counts); whether it has any (`busy`: pass 4 passes over the rest, 78% of an MRI's words
                   at 128).  A word whose neighbourhood is all on one side is known without the counting.
                   From an iso change's second level on, pass 1 marks the words whose bits changed and
                   pass 2 counts only the words next to them (6% of the MRI's words from 128 to 129): the
                   others keep their counts.
3. `_scan`         the exclusive prefix sums of the busy words' counts in the GPU's order of the words
                   (brick, then word in brick: cubes.py's docstring), so each word's vertices and
                   triangles start where the GPU puts them.
4. `_write_cubes`  per word: its vertices (axis 0, 1, 2, each by k) and its triangles (by k, then the
   (`_write` for   table's order) at its offsets; a triangle finds the vertex of an edge from the owning
   tetrahedra)     word's offset and a population count of the edge mask below the edge's bit.  Cubes
                   take each sample's gradient once, from planes of gradients and samples
                   (packed: only the samples an edge ends at); rows with no busy word are passed over.

Passes 1 and 2 run in one parallel launch (`_pack_and_count`), 3 in another (the threads take slabs of
BRICK_I planes, each started from pass 2's vertices and triangles of the planes before it), 4 in a third,
over runs of planes of axis 0 that the threads take in turn (so a thread the machine holds back leaves its
runs to the others).
Tetrahedra run the same passes with seven kinds of edge (tetra.KINDS: the axes, the face and body
diagonals) instead of three, and their table's codes.
Passes 1 to 3 are `isoscope.cpu.words`; this module writes the mesh (the arithmetic of a vertex and the
planes of gradients are `isoscope.cpu.vertices`).  The samples are read where they lie,
in their own type and memory order (`isoscope.cpu.samples`: nibabel's Fortran order, 8- and 16-bit
scans, big-endian files, negative strides); a volume in Fortran order is packed in its own memory order
(`words._pack_rows_along_0`) before pass 2.  The arithmetic of a vertex is the reference's, on each sample
as float32 and in the same order, so positions, normals and values are the reference's bit for bit.
One compiled version of a kernel serves every layout of a sample type; the JIT's output is cached on
disk (numba's cache=True).
"""
from __future__ import annotations

import numba
import numpy as np
from numba import prange

from ..core.case_table import EDGE_AXIS, EDGE_ORIGIN, CaseTable, montani_table
from ..core.layout import WORD_BITS
from ..errors import InputError
from .jit import _cached_njit, _case, _cut_cells, _launch_guard, _low_bits, _lowest_bit, _popcount, _take
from .samples import ORDER_F, SampleView, sample_view
from .vertices import _axis_vertices, _plane_gradients, _plane_spreads, _vertex
from .words import _pack_and_count, _pack_rows_along_0, _scan_slabs, _word_ranges, rows_per_block

__all__ = ["marching_cubes_compiled", "marching_tetrahedra_compiled", "CompiledCubes"]

MAX_INDEX = 2**31 - 1
"""The most vertices (and triangles) a mesh may have: its faces are int32, as scikit-image's."""

# Pass 4's runs of planes per thread: a run costs a plane of gradients more; more runs let a thread that runs
# on take up the work of one the machine holds back.
RUNS_PER_THREAD = 4


@_cached_njit(inline="always", error_model="numpy")
def _vertex_index(edges, vertex_offsets, i, j, k, kind):
    """The vertex of the edge of `kind` from (i, j, k): its word's first vertex, the word's edges of lower
    kinds, then the word's edges of `kind` below bit k."""
    w = k >> 5
    bit = k & 31
    index = vertex_offsets[i, j, w]
    for lower in range(kind):
        index += _popcount(np.int64(edges[i, j, w, lower]))
    return index + _popcount(np.int64(edges[i, j, w, kind]) & _low_bits(bit))


@_cached_njit(inline="always", error_model="numpy")
def _cube_rows(edges, vertex_offsets, i, j, w, masks, firsts):
    """masks and firsts of ROW_OWNER's rows: (0, 0, axis 0, 1, 2), (0, 1, axis 0, 2), (1, 0, axis 1, 2),
    (1, 1, axis 2)."""
    first = vertex_offsets[i, j, w]
    masks[0] = np.int64(edges[i, j, w, 0])
    firsts[0] = first
    first += _popcount(masks[0])
    masks[1] = np.int64(edges[i, j, w, 1])
    firsts[1] = first
    masks[2] = np.int64(edges[i, j, w, 2])
    firsts[2] = first + _popcount(masks[1])
    masks[3] = np.int64(edges[i, j + 1, w, 0])
    firsts[3] = vertex_offsets[i, j + 1, w]
    masks[4] = np.int64(edges[i, j + 1, w, 2])
    firsts[4] = firsts[3] + _popcount(masks[3]) + _popcount(np.int64(edges[i, j + 1, w, 1]))
    first = vertex_offsets[i + 1, j, w] + _popcount(np.int64(edges[i + 1, j, w, 0]))
    masks[5] = np.int64(edges[i + 1, j, w, 1])
    firsts[5] = first
    masks[6] = np.int64(edges[i + 1, j, w, 2])
    firsts[6] = first + _popcount(masks[5])
    masks[7] = np.int64(edges[i + 1, j + 1, w, 2])
    firsts[7] = vertex_offsets[i + 1, j + 1, w] + _popcount(np.int64(edges[i + 1, j + 1, w, 0])) + _popcount(
        np.int64(edges[i + 1, j + 1, w, 1]))


@_cached_njit(inline="always", error_model="numpy")
def _word_triangles(signs, edges, vertex_offsets, triangle_offsets, table_counts, corners, row_owner, i, j, w,
                    n2, masks, firsts, faces, cubes):
    """The triangles of the cut cells of word (i, j, w) at its triangle offset.  `cubes` (a constant): the
    rows are ROW_OWNER's, read unrolled."""
    n0, n1, nw = signs.shape
    if i + 1 >= n0 or j + 1 >= n1:
        return
    k0 = w * WORD_BITS
    along2 = _low_bits(min(WORD_BITS, n2 - 1 - k0))
    cut, a, b, c, d, a1, b1, c1, d1 = _cut_cells(signs, i, j, w, nw, along2)
    if cut == 0:
        return
    # The rows of edges the word's cells use: their masks and first vertices.
    if cubes:  # ROW_OWNER's eight rows from the four words (i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1)
        _cube_rows(edges, vertex_offsets, i, j, w, masks, firsts)
    for r in range(0 if cubes else row_owner.shape[0]):
        oi = i + row_owner[r, 0]
        oj = j + row_owner[r, 1]
        kind = row_owner[r, 2]
        masks[r] = np.int64(edges[oi, oj, w, kind])
        first = vertex_offsets[oi, oj, w]
        for lower in range(kind):
            first += _popcount(np.int64(edges[oi, oj, w, lower]))
        firsts[r] = first
    m = triangle_offsets[i, j, w]
    while cut:
        bit = _lowest_bit(cut)
        cut &= cut - 1
        case = _case(bit, a, b, c, d, a1, b1, c1, d1)
        for slot in range(table_counts[case]):
            for corner in range(3):
                faces[m, corner] = _edge_vertex(corners[case, slot, corner], bit, masks, firsts, edges,
                                                vertex_offsets, row_owner, i, j, k0)
            m += 1


@_cached_njit(inline="always", error_model="numpy")
def _edge_vertex(code, bit, masks, firsts, edges, vertex_offsets, row_owner, i, j, k0):
    """The vertex of a cell's edge: `code` is its row << 1 | its step along axis 2, the cell is at `bit` of
    word (i, j, k0 // 32), whose rows' masks and first vertices are `masks` and `firsts`."""
    r = code >> 1
    at = bit + (code & 1)
    if at < WORD_BITS:
        return firsts[r] + _popcount(masks[r] & _low_bits(at))
    # the edge at the next word's bit 0
    return _vertex_index(edges, vertex_offsets, i + row_owner[r, 0], j + row_owner[r, 1], k0 + WORD_BITS,
                         row_owner[r, 2])


@_cached_njit(parallel=True, error_model="numpy")
def _write(flat, swap, layout, sign, level, spacing, steps, signs, edges, vertex_offsets, triangle_offsets,
           table_counts, corners, row_owner, verts, faces, normals, values):
    """Pass 4 (any kinds of edge: tetrahedra's): each word's vertices and triangles at its offsets."""
    n0, n1, nw = signs.shape
    n2 = layout[6]
    rows = row_owner.shape[0]
    for i in prange(n0):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])  # a tuple in the
        # loop's body (numba's parallel loops capture no tuples): its numbers stay in registers
        masks = np.empty(rows, np.int64)
        firsts = np.empty(rows, np.int64)
        for j in range(n1):
            for w in range(nw):
                k0 = w * WORD_BITS
                n = vertex_offsets[i, j, w]
                for kind in range(steps.shape[0]):
                    bits = np.int64(edges[i, j, w, kind])
                    while bits:
                        _vertex(flat, swap, grid, sign, level, spacing, i, j, k0 + _lowest_bit(bits), steps[kind, 0],
                                steps[kind, 1], steps[kind, 2], verts, normals, values, n)
                        bits &= bits - 1
                        n += 1
                _word_triangles(signs, edges, vertex_offsets, triangle_offsets, table_counts, corners, row_owner,
                                i, j, w, n2, masks, firsts, faces, False)


@_cached_njit(parallel=True, error_model="numpy")
def _write_cubes(flat, swap, layout, sign, level, spacing, signs, edges, vertex_offsets, triangle_offsets, busy,
                 busy_rows, table_counts, corners, row_owner, workers, starts, taken, plane_rows, verts, faces, normals,
                 values, spreads, spread_level, triangles=True):
    """Pass 4 for cubes: _write's mesh, each sample's gradient computed once (not once per edge that ends
    there) into a plane of gradients, two planes held at a time (`plane_rows` samples each: _plane_rows).  The
    planes go in runs (starts[r] to starts[r + 1]) to `workers` threads, each taking the next run not yet
    taken (taken[0], reset to 0 by the caller) when it is done with one: a thread the machine holds back
    leaves its runs to the other.  With `spreads`, the values are scikit-image's at `spread_level`
    (_edge_spread), from two planes of cell spreads (_plane_spreads) made alongside the planes of gradients.
    Without `triangles`, the vertices only (the trilinear topology writes its triangles in a pass of its own,
    compiled_trilinear.py).  Words that are not `busy` (pass 2: no vertex, no triangle; most of a volume's)
    are passed over, rows without a busy word (busy_rows) at once."""
    n0, n1, nw = signs.shape
    n2 = layout[6]
    rows = row_owner.shape[0]
    for _worker in prange(workers):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])  # a tuple in the
        # loop's body (numba's parallel loops capture no tuples): its numbers stay in registers
        masks = np.empty(rows, np.int64)
        firsts = np.empty(rows, np.int64)
        cells = n1 * n2 if spreads else 1
        spreads_here = np.empty(cells, np.float32).reshape((n1, n2) if spreads else (1, 1))  # of cells (i, j, k)
        spreads_before = np.empty_like(spreads_here)  # and of cells (i - 1, j, k)
        here = np.empty((plane_rows, 4), np.float32)  # the gradients and samples of plane i (_plane_gradients)
        after = np.empty((plane_rows, 4), np.float32)  # and of plane i + 1
        here_index = np.empty((n1, nw, 2), np.int64)
        after_index = np.empty((n1, nw, 2), np.int64)
        while True:
            run = _take(taken)
            if run >= starts.shape[0] - 1:
                break
            if starts[run] < starts[run + 1]:
                _plane_gradients(flat, swap, grid, sign, spacing, edges, busy_rows, starts[run], here, here_index)
                if spreads and starts[run] > 0:
                    _plane_spreads(flat, swap, grid, signs, starts[run] - 1, spread_level, spreads_here)
            for i in range(starts[run], starts[run + 1]):
                if i + 1 < n0:
                    _plane_gradients(flat, swap, grid, sign, spacing, edges, busy_rows, i + 1, after, after_index)
                if spreads:
                    spreads_here, spreads_before = spreads_before, spreads_here
                    _plane_spreads(flat, swap, grid, signs, i, spread_level, spreads_here)
                for j in range(n1):
                    if not busy_rows[i, j]:
                        continue
                    for w in range(nw):
                        if not busy[i, j, w]:
                            continue
                        n = vertex_offsets[i, j, w]
                        n = _axis_vertices(flat, swap, grid, sign, level, spacing, edges, i, j, w, n, 0, here,
                                           here_index, after, after_index, j, verts, normals, values, spreads,
                                           spreads_before, spreads_here)
                        n = _axis_vertices(flat, swap, grid, sign, level, spacing, edges, i, j, w, n, 1, here,
                                           here_index, here, here_index, j + 1, verts, normals, values, spreads,
                                           spreads_before, spreads_here)
                        n = _axis_vertices(flat, swap, grid, sign, level, spacing, edges, i, j, w, n, 2, here,
                                           here_index, here, here_index, j, verts, normals, values, spreads,
                                           spreads_before, spreads_here)
                        if triangles:
                            _word_triangles(signs, edges, vertex_offsets, triangle_offsets, table_counts, corners,
                                            row_owner, i, j, w, n2, masks, firsts, faces, True)
                here, after = after, here
                here_index, after_index = after_index, here_index


def code_rows(codes):
    """The rows of edges a cell's table codes lie on, relative to the cell's row (i, j).  `codes[c]` is
    (di, dj, dk, kind) of code c: its edge of `kind` from cell corner (di, dj, dk).  Returns row_owner
    (R, 3): (di, dj, kind) of each row, and edge_row (C, 2): the row of code c and its step along axis 2
    (0 or 1: the edge at k or k + 1)."""
    owners = sorted({(di, dj, kind) for di, dj, dk, kind in codes})
    edge_row = [(owners.index((di, dj, kind)), dk) for di, dj, dk, kind in codes]
    return np.array(owners, np.int64), np.array(edge_row, np.int64)


CUBE_STEPS = np.eye(3, dtype=np.int64)
"""Marching cubes' edge kinds: the three axes (cubes.py)."""
ROW_OWNER, EDGE_ROW = code_rows([(int(o[0]), int(o[1]), int(o[2]), int(a)) for a, o in zip(EDGE_AXIS, EDGE_ORIGIN)])
"""The rows of a cube cell's twelve edges (axis 0 at dj 0, 1; axis 1 at di 0, 1; axis 2 at the four (di, dj))."""


def tetra_rows(kinds: np.ndarray):
    """row_owner and edge_row of the tetrahedra's codes (corner | kind << 3, tetra.edge_code)."""
    codes = []
    for code in range(8 * 8):
        corner, kind = code & 7, min(code >> 3, len(kinds) - 1)  # kind 7 is no code: any row will do
        codes.append((corner & 1, corner >> 1 & 1, corner >> 2, kind))
    return code_rows(codes)


class CompiledCubes:
    """The compiled extractor's state for one volume, read in place (`samples.sample_view`: any memory order,
    byte order and sample type, as float32): per word of 32 samples its sign bits, edge
    masks and offsets (20 bytes a word for cubes' three kinds of edge, 36 for tetrahedra's seven) and,
    made on the first iso change, its value range (8 bytes a word), so a new level packs only the words it
    cuts.  `extract(level)` returns (verts, faces, normals, values).  With `tetrahedra`, the cells are
    marched as six tetrahedra each (`isoscope.cpu.tetra`'s table, edges and order).

    `value_range`: the samples' (smallest, largest), or None where nothing has scanned them: the first
    extraction then measures it in pass 1, which reads every sample anyway, and hands it to its `accept`
    (None where a sample is NaN or infinite) before the mesh is written."""

    def __init__(self, volume: np.ndarray | SampleView, spacing, descent: bool, table: CaseTable | None = None,
                 reuse_outputs: bool = False, tetrahedra: bool = False, value_range=None):
        view = volume if isinstance(volume, SampleView) else sample_view(volume)
        self.value_range = value_range
        if tetrahedra:
            from .tetra import KINDS, tetra_table
            table = table or tetra_table()
            self._steps = KINDS.astype(np.int64)
            self._row_owner, self._edge_row = tetra_rows(KINDS)
        else:
            table = table or montani_table()
            self._steps, self._row_owner, self._edge_row = CUBE_STEPS, ROW_OWNER, EDGE_ROW
        self.view = view
        self.sign = np.float32(1.0 if descent else -1.0)
        self.spacing = np.asarray(spacing, dtype=np.float64).astype(np.float32)
        n0, n1, n2 = view.shape
        nw = -(-n2 // WORD_BITS)
        self._counts = table.counts.astype(np.int64)
        # Each triangle corner's edge as its row << 1 | its step along axis 2 (the table's -1 padding: 0).
        triangles = table.triangles.astype(np.int64)
        self._corners = np.where(triangles >= 0, self._edge_row[triangles, 0] * 2 + self._edge_row[triangles, 1],
                                 0).astype(np.int32)
        # 32-bit words and counts (a word's bits, a mesh's vertex and triangle numbers: faces are int32): the
        # passes are bound by these arrays' memory traffic, 20 bytes a word for cubes, not 48 at 64 bits.
        self._signs = np.empty((n0, n1, nw), np.uint32)
        self._edges = np.empty((n0, n1, nw, len(self._steps)), np.uint32)
        self._vertex_offsets = np.empty((n0, n1, nw), np.int32)
        self._triangle_offsets = np.empty((n0, n1, nw), np.int32)
        self._busy = np.empty((n0, n1, nw), np.bool_)  # the words with vertices or triangles (pass 2)
        self._busy_rows = np.empty((n0, n1), np.bool_)  # the rows with a busy word
        # Pass 2's counts: in the offsets' arrays (pass 3 turns them into offsets in place) until an iso change
        # keeps them apart (_keep_counts), with the last level's words, so the next counts only the words
        # next to a word whose bits changed.
        self._vertex_counts, self._triangle_counts = self._vertex_offsets, self._triangle_offsets
        self._previous = self._changed = None
        self._counted = False  # whether the counts' arrays hold the counts of the words in _signs
        self._plane_work = np.empty((n0, 3), np.int64)  # per plane: pass 4's work, vertices, triangles
        self.runs = None  # the runs of planes pass 4 hands to the threads; None: RUNS_PER_THREAD a thread
        self._taken = np.zeros(2, np.int64)  # the runs taken: in pass 4, in passes 1 and 2 (then 3)
        self._lows = self._highs = None
        self.extractions = 0
        # With reuse_outputs, the mesh arrays are kept and grown by half when too small, and extract returns
        # views of them: a new level then writes into memory already mapped (no page faults).
        self._outputs = (np.empty((0, 3), np.float32), np.empty((0, 3), np.int32), np.empty((0, 3), np.float32),
                         np.empty(0, np.float32)) if reuse_outputs else None

    def _output_arrays(self, n_vertices: int, n_triangles: int):
        if self._outputs is None:
            return (np.empty((n_vertices, 3), np.float32), np.empty((n_triangles, 3), np.int32),
                    np.empty((n_vertices, 3), np.float32), np.empty(n_vertices, np.float32))
        verts, faces, normals, values = self._outputs
        if len(verts) < n_vertices:
            size = max(n_vertices, len(verts) * 3 // 2)
            verts, normals, values = (np.empty((size, 3), np.float32), np.empty((size, 3), np.float32),
                                      np.empty(size, np.float32))
        if len(faces) < n_triangles:
            faces = np.empty((max(n_triangles, len(faces) * 3 // 2), 3), np.int32)
        self._outputs = verts, faces, normals, values
        return verts[:n_vertices], faces[:n_triangles], normals[:n_vertices], values[:n_vertices]

    recounts = True
    """Whether an iso change counts again only the words next to a change (pass 2 on a word reads the words
    after it along each axis; 1.3 MB more a million words: the counts apart from the offsets, the last
    level's words, bit masks of changes per row); up to 62 words a row (n2 <= 1984 samples)."""

    def _keep_counts(self) -> None:
        """Keep pass 2's counts apart from pass 3's offsets, and the words of the level before (recounts)."""
        if self.recounts and self._vertex_counts is self._vertex_offsets and self._signs.shape[2] <= 62:
            self._vertex_counts = np.empty_like(self._vertex_offsets)
            self._triangle_counts = np.empty_like(self._triangle_offsets)
            self._previous = np.empty_like(self._signs)
            self._changed = np.empty((*self._signs.shape[:2], 2), np.int64)

    def measure_ranges(self) -> None:
        """Measure each word's value range, so that later levels skip the words they do not cut."""
        if self._lows is None:
            # In the volume's order: pass 1 of a Fortran volume reads a word's range for every i of a row at once.
            order = "F" if self.view.order == ORDER_F else "C"
            lows = np.empty(self._signs.shape, np.float32, order=order)
            highs = np.empty(self._signs.shape, np.float32, order=order)
            view = self.view
            _word_ranges(view.flat, view.swap, view.grid, view.order, lows, highs)
            self._lows, self._highs = lows, highs

    def _plane_runs(self, workers: int) -> np.ndarray:
        """Runs of planes of equal size for passes 1 and 2."""
        n0 = self.view.shape[0]
        runs = min(self.runs or RUNS_PER_THREAD * workers, n0)
        return np.linspace(0, n0, runs + 1).astype(np.int64)

    def _runs(self, workers: int) -> np.ndarray:
        """The first plane of each run (and the end): runs of planes with equal shares of the work."""
        runs = min(self.runs or RUNS_PER_THREAD * workers, len(self._plane_work))
        done = np.cumsum(self._plane_work[:, 0])
        shares = done[-1] * np.arange(1, runs) / runs
        inner = np.searchsorted(done, shares, side="right")
        return np.concatenate(([0], inner, [len(done)])).astype(np.int64)

    def extract(self, level: float, accept=None, skimage_values: bool = False):
        """The mesh at `level`; `accept(value_range)`, where the range is measured in this pass 1, may raise
        to stop before the mesh is written (a level outside the range, a NaN sample: value_range None).
        With `skimage_values` (cubes only), the values are scikit-image's (`isoscope.cpu.skimage_values`),
        made as the vertices are, not the level."""
        with _launch_guard():
            return self._extract(level, accept, skimage_values)

    def _extract(self, level: float, accept=None, skimage_values: bool = False):
        user_level = float(level)
        if self.extractions >= 1:
            self.measure_ranges()  # an iso change: worth a pass over the samples for the words' ranges
            self._keep_counts()
        self.extractions += 1
        recount = self._counted  # the counts are those of the words of the last level: count the changes only
        self._counted = False
        if recount:  # pass 1 writes every word anew, beside the last level's
            self._signs, self._previous = self._previous, self._signs
        previous = self._previous if recount else self._signs
        changed = self._changed if recount else np.zeros((1, 1, 2), np.int64)
        level = np.float32(self.sign * np.float32(level))
        ranged = self._lows is not None
        lows = self._lows if ranged else np.empty((1, 1, 1), np.float32)
        highs = self._highs if ranged else lows
        workers = numba.get_num_threads()
        self._taken[:] = 0
        flat, swap, grid = self.view.flat, self.view.swap, self.view.grid
        along_0 = self.view.order == ORDER_F
        block_rows = rows_per_block(self.view.shape)
        measure = self.value_range is None and not ranged
        parts = -(-self.view.shape[1] // block_rows) if along_0 else self.view.shape[0]
        los, his = np.empty(parts, flat.dtype), np.empty(parts, flat.dtype)
        nans = np.zeros(parts, np.bool_)
        if along_0:  # pass 1 in the volume's memory order, then pass 2
            _pack_rows_along_0(flat, swap, grid, self.sign, level, lows, highs, ranged, self._signs, block_rows,
                               measure, los, his, nans, previous, changed, recount)
        _pack_and_count(flat, swap, grid, not along_0, self.sign, level, lows, highs, ranged, self._signs,
                        self._steps, self._counts, self._edges, self._vertex_counts, self._triangle_counts,
                        self._busy, self._busy_rows, self._plane_work, workers, self._plane_runs(workers),
                        self._taken[1:], measure, los, his, nans, previous, changed, recount)
        self._counted = self._vertex_counts is not self._vertex_offsets
        if measure:
            lo, hi = float(los.min()), float(his.max())
            finite = not nans.any() and np.isfinite(lo) and np.isfinite(hi)
            self.value_range = (lo, hi) if finite else None
            if accept is not None:
                accept(self.value_range)
        return self._write_mesh(level, user_level, workers, skimage_values)

    @staticmethod
    def _check_size(n_vertices: int, n_triangles: int, user_level: float) -> None:
        if max(n_vertices, n_triangles) > MAX_INDEX:
            raise InputError(f"the mesh at level {user_level:g} has {n_vertices:,} vertices and {n_triangles:,} "
                             f"triangles, more than int32 faces index ({MAX_INDEX:,}); extract it in pieces "
                             "(chunks=128) or at a coarser step_size")

    def _plane_rows(self) -> int:
        """The most samples a plane of gradients (_plane_gradients) holds: plane i's are the starts and ends of
        its words' edges and the ends of plane i - 1's edges along axis 0, at most 2 V(i) + V(i - 1) of
        pass 2's vertices V."""
        vertices = self._plane_work[:, 1]
        bound = 2 * vertices
        bound[1:] += vertices[:-1]
        return int(max(1, min(self.view.shape[1] * self.view.shape[2], bound.max())))

    def _write_mesh(self, level, user_level: float, workers: int, skimage_values: bool):
        """Passes 3 and 4, after the words are packed and counted."""
        flat, swap, grid = self.view.flat, self.view.swap, self.view.grid
        self._taken[1] = 0
        _scan_slabs(self._vertex_counts, self._triangle_counts, self._vertex_offsets, self._triangle_offsets,
                    self._busy, self._plane_work, workers, self._taken[1:])
        n_vertices, n_triangles = (int(n) for n in self._plane_work[:, 1:].sum(axis=0))
        self._check_size(n_vertices, n_triangles, user_level)
        verts, faces, normals, values = self._output_arrays(n_vertices, n_triangles)
        if self._steps is CUBE_STEPS:
            _write_cubes(flat, swap, grid, self.sign, level, self.spacing, self._signs, self._edges,
                         self._vertex_offsets, self._triangle_offsets, self._busy, self._busy_rows, self._counts,
                         self._corners, self._row_owner, workers, self._runs(workers), self._taken,
                         self._plane_rows(), verts, faces, normals, values, skimage_values, user_level)
        else:
            _write(flat, swap, grid, self.sign, level, self.spacing, self._steps, self._signs, self._edges,
                   self._vertex_offsets, self._triangle_offsets, self._counts, self._corners, self._row_owner,
                   verts, faces, normals, values)
        return verts, faces, normals, values


def marching_cubes_compiled(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True,
                            table: CaseTable | None = None):
    """`cubes.marching_cubes_reference`'s mesh from the compiled kernels: verts (N, 3) float32, faces (M, 3)
    int32, normals (N, 3) float32, values (N,) float32.  `volume` must already be validated."""
    return CompiledCubes(volume, spacing, descent, table).extract(level)


def marching_tetrahedra_compiled(volume: np.ndarray, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True):
    """`tetra.marching_tetrahedra_reference`'s mesh from the compiled kernels (the same arrays)."""
    return CompiledCubes(volume, spacing, descent, tetrahedra=True).extract(level)
