"""topology="trilinear" on the GPU: `isoscope.cpu.trilinear`'s mesh from compute shaders, bit for bit.

The cubes' passes with each cut cell's triangles taken by its table key instead of its case
(`TRILINEAR`, shaders/mc3_*.comp on the shared pass bodies):

3. ``mc3_classify``     per word: each cut cell's key (its case; where a decision can change the cell,
                        its faces and tunnel from its eight samples in double precision, in
                        compiled_trilinear._cell_key's order, `precise` so nothing is fused or
                        reordered), the keys' triangles and own vertices counted
4, 6. brick sums and word offsets as the cubes', the own vertices summed, scanned and offset on their own:
                        they follow every edge vertex, in the cells' order
7. ``mc3_triangles``    each cell's triangles from the key table (an image: per key a header, then its
                        own vertices' edge masks and its triangles; `TrilinearTable.packed_for_gpu`), and
                        per own vertex a job: the indices of its edge vertices, in edge order
8. ``mc_vertices``      the edge vertices, exactly the cubes'
9. ``mc3_own_vertices`` per own vertex: the mean of its edge vertices in the reference's float32
                        arithmetic, each division and the square root correctly rounded

Pass 9 reads edge vertices anywhere in the vertex buffer, so a mesh must fit one storage block (else a
GPULimitError says so; backend="cpu" makes the same mesh).
"""
from __future__ import annotations

from ..core.trilinear_table import trilinear_table
from .cell_kind import CellKind
from .cubes import Extractor
from .extraction import SurfaceExtractor
from .resident import resident_of

__all__ = ["TRILINEAR", "TrilinearExtractor", "trilinear_on"]

TRILINEAR = CellKind("trilinear cubes", classify="mc3_classify", brick_sums="mc3_brick_sums",
                     word_offsets="mc3_word_offsets", triangles="mc3_triangles", vertices="mc_vertices",
                     job_components=1, count_components=2, table=trilinear_table, job_coordinates=True,
                     own_vertices="mc3_own_vertices")
"""Cubes keyed by the trilinear table: the cubes' vertex jobs, two uints of counts a word (mc3_cells.glsl)."""


class TrilinearExtractor(Extractor):
    """`Extractor` (its volume resident, re-extracted per level) whose mesh has the trilinear interpolant's
    topology: `isoscope.cpu.trilinear.marching_cubes_trilinear`'s mesh.  `table` is the trilinear table."""
    KIND = TRILINEAR
    WORD_TRIANGLES = 0xFFFF  # mc3_cells.glsl: 16 bits


def trilinear_on(source) -> SurfaceExtractor:
    """A trilinear-topology extractor on `source`'s resident volume (an `Extractor`'s): release it first."""
    return SurfaceExtractor(resident_of(source), TRILINEAR)
