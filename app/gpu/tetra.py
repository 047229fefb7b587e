"""Marching tetrahedra on the GPU, from the volume an `Extractor` already holds.

    >>> cubes = Extractor(volume)                  # uploads the volume once
    >>> tetra = TetraExtractor(cubes)              # extracts from its resident volume
    >>> tetra.extract(0.5); tetra.mesh             # a GpuMesh with the same vertex record

So a viewer can switch between cubes and tetrahedra per extraction without uploading
again.  A `TetraExtractor` is a `SurfaceExtractor` (extraction.py) on the cubes extractor's
`ResidentVolume`, driven by the `TETRAHEDRA` cell kind: the same orchestration (skip bricks,
pack signs, classify, brick sums, scans, word offsets, triangles, vertices), the same
empty-space skipping (the brick ranges bound every sample a tetrahedron edge reaches, which are
the cubes' samples), its own sign words, counts and mesh buffers, so the two meshes live side by
side.  Passes 1-2 (`mc_bricks`, `mc_signs`) are the cubes' shaders; 3, 4, 6, 7 and 8 are
`mt_*.comp`: the pass bodies every kind shares (`cells_*.glsl`) on the tetrahedra's cells
(`mt_cells.glsl`, `mt_jobs.glsl`).  Pass 6 also orders each brick's words by their work for pass 7,
so that the words sharing a SIMD vector on llvmpipe loop about as long as each other (see
cells_word_offsets.glsl).
isoscope.cpu.tetra is its numpy mirror and says which split and why.

Pass 7 leaves the vertex jobs for pass 8 in a job buffer of its own (shaders/vertex_jobs.glsl),
two uints per vertex here (job_components; the encoding is in shaders/mt_jobs.glsl).
"""
from __future__ import annotations

from ..core.tetra_table import tetra_table
from .cell_kind import CellKind
from .extraction import SurfaceExtractor
from .resident import resident_of

__all__ = ["TETRAHEDRA", "TetraExtractor"]

TETRAHEDRA = CellKind("tetrahedra", classify="mt_classify", brick_sums="mt_brick_sums",
                      word_offsets="mt_word_offsets", triangles="mt_triangles", vertices="mt_vertices",
                      job_components=2, count_components=4, table=tetra_table)
"""Marching tetrahedra: a job is two uints, (i | j << 16, k << 3 | kind) (mt_jobs.glsl), a word's
counts four (mt_cells.glsl)."""


class TetraExtractor(SurfaceExtractor):
    """Extracts the marching-tetrahedra surface of `source`'s resident volume at any level.

    `source`: an `Extractor` (or a `ResidentVolume`), whose volume image and brick ranges it reads:
    release it before (or with) `source`.
    """

    def __init__(self, source):
        super().__init__(resident_of(source), TETRAHEDRA)
