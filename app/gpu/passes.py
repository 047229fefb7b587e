"""The passes of an extraction, compiled for one cell kind, case table and volume format, and run in order.

`PassRunner.count` runs passes 1-5 and returns the totals, `PassRunner.generate` passes 6-8 into the
mesh outputs (extraction.py lists the passes).  A mesh whose triangles or vertex jobs pass one storage
block is written a window at a time: `run_dispatches` says which bricks each triangle run takes.
The programs are the context's (programs.compute_program), so a runner owns no GL object.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..core.case_table import CaseTable
from ..core.layout import GROUP_SIZE, INDEX_BYTES, STORAGE_OFFSET_ALIGNMENT, VERTEX_BYTES, StorageBlock
from .cell_kind import CASE_TABLE_SHIFT, OWN_EDGES, CellKind
from .limits import ExtractorPlan, GPULimitError
from .outputs import MeshOutputs
from .programs import compute_program, dispatch_groups, set_uniforms
from .resident import ResidentVolume
from .scratch import ExtractionScratch


def run_dispatches(runs, firsts: np.ndarray, vertices: np.ndarray, block: int, job_bytes: int) -> list:
    """Per triangle-pass run, its dispatches: (bricks, job window) pairs, the bricks (ascending ids) and
    the window (first, count) of the job buffer that holds their vertices, as many dispatches as its
    jobs need blocks of `block` bytes.  `firsts` and `vertices` are each brick's first triangle and
    vertex, the totals last (ExtractionScratch.brick_offsets).  Each run takes only its own bricks: over
    the whole active list, every run paid for the words it skips, and its bricks, which sit together
    there, went to one of llvmpipe's threads (it hands each one contiguous N-th of a dispatch's groups)."""
    jobs_per_block = block // job_bytes
    busy = np.flatnonzero((np.diff(firsts) > 0) | (np.diff(vertices) > 0))
    start, end = firsts[busy], firsts[busy + 1]
    align = max(1, STORAGE_OFFSET_ALIGNMENT // job_bytes)  # where a binding may start
    out = []
    for _, (s, e) in runs:
        # A brick's words start their triangles at slots start .. end (its last words may have none, so
        # end itself): the run whose job slots [s, e) that closed range meets.
        bricks = busy[(start < e) & (end >= s)]
        dispatches = []
        while len(bricks):
            first = int(vertices[bricks[0]]) // align * align
            # The bricks whose vertices fit one block from `first` (at least one).
            fit = max(1, int(np.searchsorted(vertices[bricks + 1], first + jobs_per_block, side="right")))
            last = int(vertices[bricks[fit - 1] + 1])
            if last - first > jobs_per_block:
                raise GPULimitError(f"one brick of this mesh has more vertex jobs than a storage block of "
                                    f"{block:,} bytes holds from an aligned start; pick another level, or "
                                    "use backend='cpu'")
            dispatches.append((bricks[:fit], (first, last - first)))
            bricks = bricks[fit:]
        out.append(dispatches)
    return out


class PassRunner:
    """Every pass of one extractor, compiled for `kind`, `table` and `resident`'s sample format and grid."""

    def __init__(self, resident: ResidentVolume, kind: CellKind, table: CaseTable):
        self.ctx = resident.ctx
        self.kind = kind
        defines = {"MAX_TRIANGLES_PER_CELL": f"{table.max_triangles}u", "CASE_TABLE_SHIFT": f"{CASE_TABLE_SHIFT}u",
                   "TABLE_CODE_BITS": f"{table.code_bits}u", **resident.defines, **kind.defines}
        if kind.job_coordinates and resident.job_bits is not None:  # jobs hold their sample (mc_jobs.glsl)
            defines["JOB_COORDINATES"] = 1
        self._programs = {role: compute_program(self.ctx, f"{shader}.comp", defines)
                          for role, shader in kind.passes().items()}

    def set_uniforms(self, **values) -> None:
        """Set uniforms on every pass that uses them (the grid's and the level)."""
        for program in self._programs.values():
            set_uniforms(program, **values)

    def _over_active_bricks(self, role: str, scratch: ExtractionScratch, per_brick: bool = False) -> None:
        """A work group per active brick (an invocation per word), or an invocation per active brick."""
        self._programs[role].run_indirect(scratch.dispatch_args, offset=12 if per_brick else 0)
        self.ctx.memory_barrier()

    def count(self, scratch: ExtractionScratch, brick_ranges: moderngl.Buffer) -> tuple[int, int]:
        """Passes 1-5: skip, pack signs, classify, brick sums, scan; returns the totals (read back)."""
        scratch.bind_counting(brick_ranges)
        dispatch_groups(self._programs["bricks"], -(-(scratch.plan.brick_count + 1) // GROUP_SIZE))
        self.ctx.memory_barrier()
        dispatch_groups(self._programs["dispatch_args"], 1)
        self.ctx.memory_barrier()
        self._over_active_bricks("signs", scratch)
        self._over_active_bricks("classify", scratch)
        self._over_active_bricks("brick_sums", scratch, per_brick=True)
        return scratch.scan_brick_counts()

    def dispatches(self, scratch: ExtractionScratch, runs, n_vertices: int) -> list:
        """Per triangle-pass run, its (bricks, job window) dispatches: one over the active list (bricks
        None) when the triangles and jobs fit one storage block each; else `run_dispatches` on the
        bricks' offsets, read back (8 bytes a brick)."""
        block = scratch.plan.limits.max_storage_block_bytes
        job_bytes = self.kind.job_record_bytes
        windows = scratch.plan.windows(n_vertices, VERTEX_BYTES, job_bytes)
        own_jobs = scratch.own_vertices * 4 * OWN_EDGES
        if self.kind.own_vertices and (len(runs) > 1 or len(windows) > 1 or own_jobs > block):
            # Pass 9 reads edge vertices anywhere in the vertex buffer: one storage block must hold them all.
            raise GPULimitError(f"the {self.kind.name} mesh at this level ({n_vertices:,} vertices) is larger than "
                                f"one storage block of {block:,} bytes, which the GPU passes of its cells' own "
                                "vertices need; pick another level, or use backend='cpu' for the same mesh")
        if len(runs) == 1 and n_vertices <= block // job_bytes:
            return [[(None, (0, n_vertices))]]
        return run_dispatches(runs, *scratch.brick_offsets(), block, job_bytes)

    def generate(self, scratch: ExtractionScratch, outputs: MeshOutputs, plan: ExtractorPlan, n_vertices: int,
                 runs, dispatches) -> None:
        """Passes 6-8 (and 9): offsets per word, triangles and vertex jobs, vertices (and the cells' own
        vertices after them), into the mesh buffers."""
        scratch.bind_brick_offsets()  # the scan used its own slots; bind the passes' buffers again
        self._over_active_bricks("word_offsets", scratch, per_brick=True)
        triangles, vertices = self._programs["triangles"], self._programs["vertices"]
        n_edge, n_own = n_vertices - scratch.own_vertices, scratch.own_vertices
        if self.kind.own_vertices:  # one window of everything (dispatches): the own jobs are bound once
            outputs.own_jobs.bind_to_storage_buffer(StorageBlock.OWN_JOBS)
            set_uniforms(triangles, u_own_base=n_edge)
        jobs, job_bytes = outputs.jobs, self.kind.job_record_bytes
        for (window, job_slots), run_dispatch_list in zip(runs, dispatches):
            # Each run writes the triangles in its window of the index buffer (usually the only one)
            # and the vertex jobs of the words whose triangles start there (triangle_runs.glsl), into
            # the window of the job buffer that holds their vertices (vertex_jobs.glsl).
            outputs.bind_window(StorageBlock.MESH_INDICES, outputs.index_buffer, window, INDEX_BYTES)
            for bricks, job_window in run_dispatch_list:
                outputs.bind_window(StorageBlock.VERTEX_JOBS, jobs, job_window, job_bytes)
                set_uniforms(triangles, u_triangle_window=window, u_job_slots=job_slots, u_job_first=job_window[0])
                if bricks is None:
                    self._over_active_bricks("triangles", scratch)
                    continue
                scratch.bind_run_list(bricks)
                dispatch_groups(triangles, len(bricks))
                self.ctx.memory_barrier()
        for window in plan.windows(n_edge, VERTEX_BYTES, job_bytes):
            outputs.bind_window(StorageBlock.MESH_VERTICES, outputs.vertex_buffer, window, VERTEX_BYTES)
            outputs.bind_window(StorageBlock.VERTEX_JOBS, jobs, window, job_bytes)
            set_uniforms(vertices, u_vertex_count=window[1])
            dispatch_groups(vertices, -(-window[1] // GROUP_SIZE))
        self.ctx.memory_barrier()
        if n_own:
            own = self._programs["own_vertices"]
            outputs.bind_window(StorageBlock.MESH_VERTICES, outputs.vertex_buffer, (0, n_vertices), VERTEX_BYTES)
            outputs.own_jobs.bind_to_storage_buffer(StorageBlock.OWN_JOBS)
            set_uniforms(own, u_own_base=n_edge, u_own_count=n_own)
            dispatch_groups(own, -(-n_own // GROUP_SIZE))
            self.ctx.memory_barrier()
