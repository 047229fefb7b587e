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

Passes 1-2 are the same for every kind; the kind names the shaders of 3, 4 and 6-8: each a short
``mc_*.comp`` or ``mt_*.comp`` that includes the kind's GLSL (its counts and jobs: ``mc_cells.glsl``,
``mc_jobs.glsl`` or ``mt_cells.glsl``, ``mt_jobs.glsl``) and the pass's body that every kind shares
(``cells_<pass>.glsl``), compiled with the kind's `CellKind.defines`.  Between passes
1 and 2, ``mc_dispatch_args`` turns the active count into the indirect dispatch sizes of passes 2-4,
6 and 7, so those touch only the bricks whose range contains the new level.  Read-backs per
extraction: the two totals (8 bytes), which size the outputs, and the active-brick count (4 bytes).
What the passes read often (the volume, per-word signs, counts and offsets) lives in images and the
case table in an image too: on llvmpipe an SSBO load costs 4-6 times an imageLoad (mc_common.glsl).

Each extractor owns its sign words, counts, offsets, work buffers and mesh buffers (so meshes of two
kinds live side by side), and releases them; the resident volume is its maker's to release.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import moderngl
import numpy as np

from .. import validation
from ..core.case_table import CaseTable
from ..core.layout import (
    GROUP_SIZE,
    INDEX_BYTES,
    STORAGE_OFFSET_ALIGNMENT,
    VERTEX_BYTES,
    ImageUnit,
    StorageBlock,
)
from ..errors import ReleasedError
from .buffers import GrowableBuffer
from .limits import GPULimitError
from .mesh import GpuMesh
from .programs import compute_program, dispatch_groups, set_uniforms, timer_queries
from .resident import ResidentVolume
from .scan import ExclusiveScan

CASE_TABLE_SHIFT = 10
"""The case-table image is 2^10 texels wide (see mc_case_table.glsl)."""

_UINT_IMAGE_FORMATS = {1: "r32ui", 2: "rg32ui", 4: "rgba32ui"}
_UINT_TYPES = {1: "uint", 2: "uvec2", 3: "uvec3", 4: "uvec4"}

SHARED_PASSES = {"bricks": "mc_bricks", "dispatch_args": "mc_dispatch_args", "signs": "mc_signs"}
"""The passes every kind of cell runs as they are (by role)."""


def case_table_image(ctx: moderngl.Context, table: CaseTable) -> moderngl.Texture:
    """`table`'s words (CaseTable.packed_for_gpu) in an r32ui image 2^CASE_TABLE_SHIFT texels wide."""
    words = table.packed_for_gpu()
    width = 1 << CASE_TABLE_SHIFT
    words = np.concatenate([words, np.zeros(-len(words) % width, np.uint32)])
    return ctx.texture((width, len(words) // width), 1, words.tobytes(), dtype="u4")


@dataclass(frozen=True)
class CellKind:
    """What differs between cubes and tetrahedra: the shaders of the per-kind passes and the sizes
    of what they write."""
    name: str
    classify: str
    brick_sums: str
    word_offsets: str
    triangles: str
    vertices: str
    job_components: int
    """uints per vertex job (shaders/vertex_jobs.glsl)."""
    count_components: int
    """Components of the per-word counts image."""
    table: Callable[[], CaseTable]
    """The case table it marches by default."""
    job_coordinates: bool = False
    """Whether its vertex jobs hold their sample's coordinates where the grid allows (JOB_COORDINATES)."""

    @property
    def defines(self) -> dict[str, str]:
        """What its passes are compiled with, from the sizes above (the shared pass bodies, shaders/cells_*.glsl,
        declare the counts image and the job buffer by these): the counts image's format and a job's type."""
        return {"WORD_COUNTS_FORMAT": _UINT_IMAGE_FORMATS[self.count_components],
                "VERTEX_JOB": _UINT_TYPES[self.job_components]}

    def passes(self) -> dict[str, str]:
        """Every pass's shader, by role."""
        return {**SHARED_PASSES, "classify": self.classify, "brick_sums": self.brick_sums,
                "word_offsets": self.word_offsets, "triangles": self.triangles, "vertices": self.vertices}


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
        defines = {"MAX_TRIANGLES_PER_CELL": f"{self.table.max_triangles}u", "CASE_TABLE_SHIFT": f"{CASE_TABLE_SHIFT}u",
                   "TABLE_CODE_BITS": f"{self.table.code_bits}u", **volume.defines, **kind.defines}
        if kind.job_coordinates and volume.job_bits is not None:  # jobs hold their sample (mc_jobs.glsl)
            defines["JOB_COORDINATES"] = 1
        self._passes = {role: compute_program(self.ctx, f"{shader}.comp", defines)
                        for role, shader in kind.passes().items()}
        self.n_vertices = self.n_triangles = self.active_bricks = 0
        self.level: float | None = None
        self.last_extract_ms = 0.0  # wall time of extract(), read-back included
        self.last_gpu_ms = 0.0  # GPU time of its passes, by GL timer queries (llvmpipe reports ~0)
        # Two queries: one around counting, one around output, so the CPU's read-back of the totals
        # between them is not counted as GPU time.  The context's (programs.timer_queries): moderngl
        # cannot delete a query, so one pair per context rather than one per extractor.
        self._timers = timer_queries(self.ctx)
        self._owned: list = []  # every fixed-size GL object allocated here, released together
        self._outputs: dict[str, GrowableBuffer] = {}  # the mesh buffers and the vertex jobs
        self._run_list: moderngl.Buffer | None = None  # a large mesh's per-run brick list, made when needed
        self._scan: ExclusiveScan | None = None
        try:
            self._allocate()
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

    @property
    def job_record_bytes(self) -> int:
        return 4 * self.kind.job_components

    # -- set-up -----------------------------------------------------------------------------

    def _allocate(self) -> None:
        ctx, plan = self.ctx, self.plan
        self._sign_words = self._own(ctx.texture(plan.word_image_size, 1, dtype="u4"))
        self._word_counts = self._own(ctx.texture(plan.word_image_size, self.kind.count_components, dtype="u4"))
        self._word_offsets = self._own(ctx.texture(plan.word_image_size, 2, dtype="u4"))  # (first vertex, triangle)
        sizes = plan.storage_elements()
        self._brick_vertex_offsets = self._storage(sizes["brick vertex offsets"])
        self._brick_triangle_offsets = self._storage(sizes["brick triangle offsets"])
        self._active_bricks = self._storage(sizes["active bricks"])
        self._brick_states = self._storage(sizes["brick states"])  # of its own sign words
        self._brick_states.clear()  # 0: the sign words hold nothing known (mc_bricks.comp)
        self._dispatch_args = self._own(ctx.buffer(reserve=24))  # groups per active brick, then per 64 bricks
        self._case_table = self._own(case_table_image(ctx, self.table))
        self._scan = ExclusiveScan(ctx)
        for name, minimum in (("vertices", VERTEX_BYTES), ("indices", INDEX_BYTES), ("jobs", self.job_record_bytes)):
            self._outputs[name] = GrowableBuffer(ctx, minimum)

    def _own(self, gl_object):
        self._owned.append(gl_object)
        return gl_object

    def _storage(self, elements: int) -> moderngl.Buffer:
        """A work buffer; plan_extractor has already checked its size against the limit."""
        return self._own(self.ctx.buffer(reserve=max(elements, 1) * 4))

    # The mesh buffers (None only after release, or where a failed allocation left none).
    @property
    def vertex_buffer(self) -> moderngl.Buffer | None:
        return self._outputs["vertices"].buffer if self._outputs else None

    @property
    def index_buffer(self) -> moderngl.Buffer | None:
        return self._outputs["indices"].buffer if self._outputs else None

    @property
    def vertex_jobs(self) -> moderngl.Buffer | None:
        return self._outputs["jobs"].buffer if self._outputs else None

    def _bind_images(self) -> None:
        self.resident.bind()
        self._sign_words.bind_to_image(ImageUnit.SIGN_WORDS, read=True, write=True)
        self._word_counts.bind_to_image(ImageUnit.WORD_COUNTS, read=True, write=True)
        self._word_offsets.bind_to_image(ImageUnit.WORD_OFFSETS, read=True, write=True)
        self._case_table.bind_to_image(ImageUnit.CASE_TABLE, read=True, write=False)  # see mc_case_table.glsl

    def _ensure_output(self, n_vertices: int, n_triangles: int) -> None:
        """Grow the mesh buffers and the vertex-job buffer to fit (buffers.GrowableBuffer).  A failed
        allocation leaves an empty mesh and an extractor that can extract again.

        The buffers may outgrow one storage block: the passes then write them a window at a time."""
        for name, needed in (("vertices", n_vertices * VERTEX_BYTES), ("indices", n_triangles * INDEX_BYTES),
                             ("jobs", n_vertices * self.job_record_bytes)):
            try:
                self._outputs[name].ensure(needed)
            except moderngl.Error as exc:
                self.n_vertices = self.n_triangles = 0  # an empty mesh, in a small buffer where one can be had
                self.level = None
                raise GPULimitError(
                    f"the mesh at this level ({n_vertices} vertices, {n_triangles} triangles) needs a "
                    f"{max(needed, 1) / 2**20:.1f} MiB buffer that this GPU could not allocate ({exc}); pick "
                    "another level, crop or downsample the volume, or use backend='cpu'") from None

    # -- extraction -------------------------------------------------------------------------

    def _set_common_uniforms(self, level: float) -> None:
        sign = self.resident.sign
        values = dict(self.resident.grid_uniforms, u_level=float(np.float32(sign * level)), u_sign=sign)
        for program in self._passes.values():
            set_uniforms(program, **values)

    @staticmethod
    def _bind(*slots: tuple[int, moderngl.Buffer]) -> None:
        for binding, buffer in slots:
            buffer.bind_to_storage_buffer(binding)

    def _run_over_active_bricks(self, role: str, per_brick: bool = False) -> None:
        """A work group per active brick (an invocation per word), or an invocation per active brick."""
        self._passes[role].run_indirect(self._dispatch_args, offset=12 if per_brick else 0)
        self.ctx.memory_barrier()

    def extract(self, level: float) -> tuple[int, int]:
        """Extract the surface at `level` into vertex_buffer/index_buffer; returns (vertices, triangles)."""
        self._check_alive()
        level = validation.as_level(level, self.value_range)
        start = time.perf_counter()
        self._set_common_uniforms(level)
        self._bind_images()
        self._active_bricks.write(b"\0\0\0\0")  # the active count, appended to by mc_bricks
        with self._timers[0]:
            n_vertices, n_triangles = self._count()
        # Planned (and refused, where a limit is passed) before the outputs grow: a refused level leaves
        # the last mesh intact.
        runs = self.plan.triangle_runs(n_triangles)
        dispatches = self._run_bricks(runs, n_vertices)
        self._ensure_output(n_vertices, n_triangles)
        if n_vertices:
            with self._timers[1]:
                self._generate(n_vertices, runs, dispatches)
        self.ctx.finish()

        self.n_vertices, self.n_triangles, self.level = n_vertices, n_triangles, level
        self.active_bricks = int(np.frombuffer(self._active_bricks.read(4), np.uint32)[0])
        self.last_extract_ms = (time.perf_counter() - start) * 1000.0
        self.last_gpu_ms = (self._timers[0].elapsed + (self._timers[1].elapsed if n_vertices else 0)) / 1e6
        return n_vertices, n_triangles

    def _count(self) -> tuple[int, int]:
        """Passes 1-5: skip, pack signs, classify, brick sums, scan; returns the totals (read back)."""
        self._bind((StorageBlock.BRICK_VERTICES, self._brick_vertex_offsets),
                   (StorageBlock.BRICK_TRIANGLES, self._brick_triangle_offsets),
                   (StorageBlock.ACTIVE_BRICKS, self._active_bricks),
                   (StorageBlock.BRICK_RANGES, self.resident.brick_ranges),
                   (StorageBlock.DISPATCH_ARGS, self._dispatch_args), (StorageBlock.BRICK_STATES, self._brick_states))
        dispatch_groups(self._passes["bricks"], -(-(self.brick_count + 1) // GROUP_SIZE))
        self.ctx.memory_barrier()
        dispatch_groups(self._passes["dispatch_args"], 1)
        self.ctx.memory_barrier()
        self._run_over_active_bricks("signs")
        self._run_over_active_bricks("classify")
        self._run_over_active_bricks("brick_sums", per_brick=True)

        self._scan(self._brick_vertex_offsets, self.brick_count + 1)
        self._scan(self._brick_triangle_offsets, self.brick_count + 1)
        total_at = self.brick_count * 4
        n_vertices = int(np.frombuffer(self._brick_vertex_offsets.read(4, total_at), np.uint32)[0])
        n_triangles = int(np.frombuffer(self._brick_triangle_offsets.read(4, total_at), np.uint32)[0])
        return n_vertices, n_triangles

    def _generate(self, n_vertices: int, runs, dispatches) -> None:
        """Passes 6-8: offsets per word, triangles and vertex jobs, vertices, into the mesh buffers."""
        # The scan used its own slots; bind the passes' buffers again.
        self._bind((StorageBlock.BRICK_VERTICES, self._brick_vertex_offsets),
                   (StorageBlock.BRICK_TRIANGLES, self._brick_triangle_offsets))
        self._run_over_active_bricks("word_offsets", per_brick=True)
        triangles, vertices = self._passes["triangles"], self._passes["vertices"]
        jobs, job_bytes = self.vertex_jobs, self.job_record_bytes
        for (window, job_slots), run_dispatches in zip(runs, dispatches):
            # Each run writes the triangles in its window of the index buffer (usually the only one)
            # and the vertex jobs of the words whose triangles start there (triangle_runs.glsl), into
            # the window of the job buffer that holds their vertices (vertex_jobs.glsl).
            self._bind_window(StorageBlock.MESH_INDICES, self.index_buffer, window, INDEX_BYTES)
            for bricks, job_window in run_dispatches:
                self._bind_window(StorageBlock.VERTEX_JOBS, jobs, job_window, job_bytes)
                set_uniforms(triangles, u_triangle_window=window, u_job_slots=job_slots, u_job_first=job_window[0])
                if bricks is None:
                    self._run_over_active_bricks("triangles")
                    continue
                self._run_list.write(np.concatenate([[len(bricks)], bricks]).astype(np.uint32))
                # In the active list's place (mc_active_bricks.glsl).
                self._run_list.bind_to_storage_buffer(StorageBlock.ACTIVE_BRICKS)
                dispatch_groups(triangles, len(bricks))
                self.ctx.memory_barrier()
        for window in self.plan.windows(n_vertices, VERTEX_BYTES, job_bytes):
            self._bind_window(StorageBlock.MESH_VERTICES, self.vertex_buffer, window, VERTEX_BYTES)
            self._bind_window(StorageBlock.VERTEX_JOBS, jobs, window, job_bytes)
            set_uniforms(vertices, u_vertex_count=window[1])
            dispatch_groups(vertices, -(-window[1] // GROUP_SIZE))
        self.ctx.memory_barrier()

    def _run_bricks(self, runs, n_vertices: int) -> list:
        """Per triangle-pass run, its dispatches: (bricks, job window) pairs, the bricks (ascending ids, or
        None for the active list) and the window (first, count) of the job buffer that holds their
        vertices.  A mesh whose triangles and jobs fit one storage block each is one dispatch over the
        active list.  Otherwise the bricks' scanned offsets are read back (8 bytes a brick) and each run
        takes only its own bricks, as many dispatches as its jobs need blocks: over the whole list, every
        run paid for the words it skips, and its bricks, which sit together there, went to one of
        llvmpipe's threads (it hands each one contiguous N-th of a dispatch's groups)."""
        block = self.plan.limits.max_storage_block_bytes
        jobs_per_block = block // self.job_record_bytes
        if len(runs) == 1 and n_vertices <= jobs_per_block:
            return [[(None, (0, n_vertices))]]
        count = self.brick_count + 1
        firsts = np.frombuffer(self._brick_triangle_offsets.read(4 * count), np.uint32).astype(np.int64)
        vertices = np.frombuffer(self._brick_vertex_offsets.read(4 * count), np.uint32).astype(np.int64)
        busy = np.flatnonzero((np.diff(firsts) > 0) | (np.diff(vertices) > 0))
        start, end = firsts[busy], firsts[busy + 1]
        if self._run_list is None:
            self._run_list = self._own(self.ctx.buffer(reserve=4 * count))
        align = max(1, STORAGE_OFFSET_ALIGNMENT // self.job_record_bytes)  # where a binding may start
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

    @staticmethod
    def _bind_window(binding: int, buffer: moderngl.Buffer, window: tuple[int, int], record_bytes: int) -> None:
        """Bind records first .. first + count of `buffer` (one record for an empty window)."""
        first, count = window
        buffer.bind_to_storage_buffer(binding, offset=first * record_bytes, size=max(count, 1) * record_bytes)

    # -- the mesh and memory ---------------------------------------------------------------------

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
        images = sum(t.width * t.height * t.components * 4 for t in self._word_images())
        return images + self.job_bytes() + sum(b.size for b in self._scratch_buffers()) + self._scan.scratch_bytes()

    def gpu_bytes(self) -> int:
        """The GL memory this extractor holds: scratch_bytes and the mesh buffers."""
        if not self._owned:
            return 0
        return self.scratch_bytes() + sum(self._outputs[name].size for name in ("vertices", "indices"))

    def job_bytes(self) -> int:
        """The vertex-job buffer's share of scratch_bytes: job_components uints per vertex, grown with the mesh."""
        return self._outputs["jobs"].size if self._outputs else 0

    def _word_images(self) -> tuple[moderngl.Texture, ...]:
        """The images scratch_bytes counts: the per-word ones and the case table."""
        return (self._sign_words, self._word_counts, self._word_offsets, self._case_table)

    def _scratch_buffers(self) -> tuple[moderngl.Buffer, ...]:
        return (self._brick_vertex_offsets, self._brick_triangle_offsets, self._active_bricks, self._brick_states,
                self._dispatch_args)

    def release(self) -> None:
        """Free every GL object this extractor made; safe to call twice, or on a half-built one.  The
        resident volume is not its to free."""
        self._released = True
        for obj in self._owned:
            obj.release()
        self._owned.clear()
        for buffer in self._outputs.values():
            buffer.release()
        self._outputs.clear()
        self._run_list = None
        if self._scan is not None:
            self._scan.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
