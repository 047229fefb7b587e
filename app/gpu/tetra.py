"""Marching tetrahedra on the GPU, from the volume an `Extractor` already holds.

    >>> cubes = Extractor(volume)                  # uploads the volume once
    >>> tetra = TetraExtractor(cubes)              # borrows its volume image and brick ranges
    >>> tetra.extract(0.5); tetra.mesh             # a GpuMesh with the same vertex record

So a viewer can switch between cubes and tetrahedra per extraction without uploading
again.  A `TetraExtractor` is an `Extractor` whose cell passes are the tetrahedra's: the
same orchestration (`extract`: skip bricks, pack signs, classify, brick sums, scans,
word offsets, triangles, vertices), the same empty-space skipping (the brick ranges
bound every sample a tetrahedron edge reaches, which are the cubes' samples), its own
sign words, counts and mesh buffers, so the two meshes live side by side.  Passes 1-2
(`mc_bricks`, `mc_signs`) are the cubes' shaders; 3, 4, 6, 7 and 8 are `mt_*.comp`.  Pass 6
also orders each brick's words by their work for pass 7, so that the words sharing a SIMD
vector on llvmpipe loop about as long as each other (see mt_word_offsets.comp).
`app/reference_tetra.py` is its numpy mirror and says which split and why.

Pass 7 leaves the vertex jobs for pass 8 in a job buffer of its own (shaders/vertex_jobs.glsl),
two uints per vertex here (JOB_COMPONENTS; the encoding is in shaders/mt_jobs.glsl).
"""
from __future__ import annotations

from ..core.layout import INDEX_BYTES, VERTEX_BYTES
from ..cpu.tetra import tetra_table
from .cubes import CASE_TABLE_SHIFT, Extractor, case_table_image
from .programs import compute_program
from .scan import ExclusiveScan

__all__ = ["TetraExtractor"]

# The Extractor's pass names, and the shader that runs each here.
PASSES = {"mc_bricks": "mc_bricks", "mc_dispatch_args": "mc_dispatch_args", "mc_signs": "mc_signs",
          "mc_classify": "mt_classify", "mc_brick_sums": "mt_brick_sums", "mc_word_offsets": "mt_word_offsets",
          "mc_triangles": "mt_triangles", "mc_vertices": "mt_vertices"}


class TetraExtractor(Extractor):
    """Extracts the marching-tetrahedra surface of `source`'s resident volume at any level.

    It borrows `source`'s volume image and brick ranges: release it before (or with) `source`.
    """

    JOB_COMPONENTS = 2  # (i | j << 16, k << 3 | kind): see mt_jobs.glsl

    def __init__(self, source: Extractor):
        self.source = source
        self.spacing, self.descent, self.shape = source.spacing, source.descent, source.shape
        self.value_range, self.ctx, self.plan = source.value_range, source.ctx, source.plan
        self.table = tetra_table()
        self._grid_uniforms = source.grid_uniforms
        self._volume = source.volume_texture
        self.volume_defines = source.volume_defines
        self._brick_ranges = source.brick_ranges

        defines = {"MAX_TRIANGLES_PER_CELL": f"{self.table.max_triangles}u", "CASE_TABLE_SHIFT": f"{CASE_TABLE_SHIFT}u",
                   **self.volume_defines}
        self._passes = {name: compute_program(self.ctx, f"{shader}.comp", defines) for name, shader in PASSES.items()}

        self.n_vertices = self.n_triangles = self.active_bricks = 0
        self.level = None
        self.last_extract_ms = self.last_gpu_ms = 0.0
        self._owned = []
        self.vertex_buffer = self.index_buffer = self.vertex_jobs = None
        self._scan = None
        try:
            self._allocate_scratch()
        except BaseException:
            self.release()
            raise

    def _allocate_scratch(self) -> None:
        ctx, plan = self.ctx, self.plan
        self._sign_words = self._own(ctx.texture(plan.word_image_size, 1, dtype="u4"))
        self._word_counts = self._own(ctx.texture(plan.word_image_size, 4, dtype="u4"))  # see mt_common.glsl
        self._word_offsets = self._own(ctx.texture(plan.word_image_size, 2, dtype="u4"))
        sizes = plan.storage_elements()
        self._brick_vertex_offsets = self._storage(sizes["brick vertex offsets"])
        self._brick_triangle_offsets = self._storage(sizes["brick triangle offsets"])
        self._active_bricks = self._storage(sizes["active bricks"])
        self._brick_states = self._storage(sizes["brick states"])  # of its own sign words
        self._brick_states.clear()
        self._dispatch_args = self._own(ctx.buffer(reserve=24))
        self._case_table = self._own(case_table_image(ctx, self.table))
        self._scan = ExclusiveScan(ctx)
        self.vertex_buffer = ctx.buffer(reserve=VERTEX_BYTES)
        self.index_buffer = ctx.buffer(reserve=INDEX_BYTES)
        self.vertex_jobs = ctx.buffer(reserve=self.job_record_bytes)
        self._timers = (ctx.query(time=True), ctx.query(time=True))

    def _scratch_buffers(self):
        """Its own work buffers (the brick ranges are the source's)."""
        return (self._brick_vertex_offsets, self._brick_triangle_offsets, self._active_bricks, self._brick_states,
                self._dispatch_args)
