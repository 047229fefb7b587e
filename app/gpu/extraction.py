"""Extraction on the GPU, by any kind of cell: the passes, their buffers and the mesh they write.

A `SurfaceExtractor` extracts the isosurface of a `ResidentVolume` (resident.py) at any level,
marching the cells a `CellKind` names: cubes (cubes.py) or tetrahedra (tetra.py).  Both kinds run
the same orchestration, one compute shader a pass:

1. ``mc_bricks``        per brick: bricks the level cannot cut hold constant signs (written when
                        they change side) and are skipped from here on; the rest go on an active list
2. ``mc_signs``         active bricks: pack inside bits 32 per word along axis 2
3. classify             active bricks: per word, vertices owned (per axis) and triangles
4. brick sums           per active brick: its totals
5. ``scan``             exclusive scans of the per-brick totals -> offsets and grand totals
6. word offsets         per active brick: each word's first vertex and triangle, and the order in
                        which pass 7 takes the brick's words (by their work: see the shaders)
7. triangles            active bricks: triangle indices into the shared vertices, and for each
                        vertex the edge it lies on (a job for pass 8, in a buffer of its own:
                        shaders/vertex_jobs.glsl)
8. vertices             one invocation per vertex: position, value and outward normal
9. own vertices         only where the kind's cells add vertices of their own (the trilinear topology,
                        trilinear.py): one invocation per such vertex, the mean of edge vertices

Passes 1-2 are the same for every kind; the kind names the shaders of 3, 4 and 6-8 (cell_kind.py).  Between
passes 1 and 2, ``mc_dispatch_args`` turns the active count into the indirect dispatch sizes of passes
2-4, 6 and 7, so those touch only the bricks whose range contains the new level.  Read-backs per
extraction: the two totals (8 bytes), which size the outputs, and the active-brick count (4 bytes).
What the passes read often (the volume, per-word signs, counts and offsets) lives in images and the
case table in an image too: on llvmpipe an SSBO load costs 4-6 times an imageLoad (mc_common.glsl).

A `SurfaceExtractor` checks the level, times and counts, and puts together one object per job, each
the one owner of the GL objects it makes and the one to release them:

- `PassRunner` (passes.py, `passes`): the compiled passes, run in order (the programs are the context's)
- `ExtractionScratch` (scratch.py, `scratch`): sign words, counts, offsets, work buffers, case table
- `MeshOutputs` (outputs.py, `outputs`): the vertex, index and vertex-job buffers, grown with the mesh

So meshes of two kinds live side by side; the resident volume is its maker's to release.
"""
from __future__ import annotations

import time

import numpy as np

from .. import validation
from ..core.case_table import CaseTable
from ..errors import ReleasedError
from .cell_kind import OWN_EDGES, CellKind
from .limits import GPULimitError
from .mesh import GpuMesh
from .outputs import MeshOutputs
from .passes import PassRunner
from .programs import timer_queries
from .resident import ResidentVolume
from .scratch import ExtractionScratch

__all__ = ["CellKind", "SurfaceExtractor"]


class SurfaceExtractor:
    """Extracts the surface of `volume` at any level by the cells of `kind`.

    >>> ex = SurfaceExtractor(volume, CUBES)
    >>> n_vertices, n_triangles = ex.extract(0.5)   # the mesh stays in ex.mesh's buffers
    >>> verts, faces, normals, values = ex.read_mesh()
    """

    def __init__(self, volume: ResidentVolume, kind: CellKind, table: CaseTable | None = None):
        self._released = False
        self.resident = volume
        self.kind = kind
        self.ctx = volume.ctx
        self.table = table or kind.table()
        self.passes = PassRunner(volume, kind, self.table)
        self.n_vertices = self.n_triangles = self.active_bricks = 0
        self.level: float | None = None
        self.last_extract_ms = 0.0  # wall time of extract(), read-back included
        self.last_gpu_ms = 0.0  # GPU time of its passes, by GL timer queries (llvmpipe reports ~0)
        # Two queries: one around counting, one around output, so the CPU's read-back of the totals
        # between them is not counted as GPU time.  The context's (programs.timer_queries): moderngl
        # cannot delete a query, so one pair per context rather than one per extractor.
        self._timers = timer_queries(self.ctx)
        self.scratch: ExtractionScratch | None = None
        self.outputs: MeshOutputs | None = None
        try:
            self.scratch = ExtractionScratch(self.ctx, self.plan, kind.count_components, self.table,
                                             kind.offset_components, own_vertices=bool(kind.own_vertices))
            self.outputs = MeshOutputs(self.ctx, kind.job_record_bytes, 4 * OWN_EDGES if kind.own_vertices else 0)
        except BaseException:
            self.release()
            raise

    # -- what it extracts from ----------------------------------------------------------------

    @property
    def plan(self):
        """The sizes of the GPU objects for this volume (limits.ExtractorPlan)."""
        return self.resident.plan

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.resident.shape

    @property
    def spacing(self):
        return self.resident.spacing

    @property
    def descent(self) -> bool:
        return self.resident.descent

    @property
    def value_range(self):
        return self.resident.value_range

    @property
    def brick_count(self) -> int:
        return self.plan.brick_count

    # -- extraction -------------------------------------------------------------------------

    def extract(self, level: float) -> tuple[int, int]:
        """Extract the surface at `level` into vertex_buffer/index_buffer; returns (vertices, triangles)."""
        self._check_alive()
        level = validation.as_level(level, self.value_range)
        start = time.perf_counter()
        sign = self.resident.sign
        self.passes.set_uniforms(**self.resident.grid_uniforms, u_level=float(np.float32(sign * level)), u_sign=sign)
        self.resident.bind()
        self.scratch.bind_images()
        self.scratch.clear_active_count()
        with self._timers[0]:
            n_vertices, n_triangles = self.passes.count(self.scratch, self.resident.brick_ranges)
        # Planned (and refused, where a limit is passed) before the outputs grow: a refused level leaves
        # the last mesh intact.
        runs = self.plan.triangle_runs(n_triangles)
        dispatches = self.passes.dispatches(self.scratch, runs, n_vertices)
        try:
            self.outputs.ensure(n_vertices, n_triangles, self.scratch.own_vertices)
        except GPULimitError:
            self.n_vertices = self.n_triangles = 0  # an empty mesh, in a small buffer where one can be had
            self.level = None
            raise
        if n_vertices:
            with self._timers[1]:
                self.passes.generate(self.scratch, self.outputs, self.plan, n_vertices, runs, dispatches)
        self.ctx.finish()

        self.n_vertices, self.n_triangles, self.level = n_vertices, n_triangles, level
        self.active_bricks = self.scratch.active_count()
        self.last_extract_ms = (time.perf_counter() - start) * 1000.0
        self.last_gpu_ms = (self._timers[0].elapsed + (self._timers[1].elapsed if n_vertices else 0)) / 1e6
        return n_vertices, n_triangles

    # -- the mesh and memory ---------------------------------------------------------------------

    # The mesh buffers (None only after release, or where a failed allocation left none).
    @property
    def vertex_buffer(self):
        return self.outputs.vertex_buffer if self.outputs else None

    @property
    def index_buffer(self):
        return self.outputs.index_buffer if self.outputs else None

    @property
    def mesh(self) -> GpuMesh:
        """The last extraction, a view of this extractor's buffers (valid until the next extract or release)."""
        return GpuMesh(self.vertex_buffer, self.index_buffer, self.n_vertices, self.n_triangles)

    def read_mesh(self):
        """The last extraction as numpy arrays: verts, faces, normals, values (skimage's layout)."""
        self._check_alive()
        return self.mesh.read()

    def _check_alive(self) -> None:
        if self._released:
            raise ReleasedError(f"this {type(self).__name__} was released (release(), or its with block ended): "
                                "its GPU memory is gone; make a new one")

    def scratch_bytes(self) -> int:
        """GPU memory of its own beyond the mesh buffers (the vertex-job buffer included)."""
        return (self.scratch.nbytes() if self.scratch else 0) + self.job_bytes()

    def gpu_bytes(self) -> int:
        """The GL memory this extractor holds: scratch_bytes and the mesh buffers."""
        if not (self.scratch and self.scratch.allocated):
            return 0
        return self.scratch_bytes() + self.outputs.mesh_bytes()

    def job_bytes(self) -> int:
        """The vertex-job buffer's share of scratch_bytes: job_components uints per vertex, grown with the mesh."""
        return self.outputs.job_bytes() if self.outputs else 0

    def release(self) -> None:
        """Free every GL object this extractor made; safe to call twice, or on a half-built one.  The
        resident volume is not its to free."""
        self._released = True
        for part in (self.scratch, self.outputs):
            if part is not None:
                part.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
