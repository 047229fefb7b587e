"""The GPU marching-cubes extractor: a volume resident in a 3-D texture, re-extracted per level.

Passes (one compute shader each, as in NVIDIA's CUDA sample, but producing an
indexed mesh and sized from the scans, so nothing is ever dropped):

0. ``mc_row_range``, ``mc_brick_range``  once per volume: the value range of each
   brick (8 x 8 rows x 32 samples, plus the halo its cells reach), for skipping
1. ``mc_bricks``       per brick: bricks the level cannot cut hold constant signs (written
                       when they change side) and are skipped from here on; the rest go on
                       an active list
2. ``mc_signs``        active bricks: pack inside bits 32 per word along axis 2
3. ``mc_classify``     active bricks: per word, vertices owned (per axis) and triangles
4. ``mc_brick_sums``   per active brick: its totals
5. ``scan``            exclusive scans of the per-brick totals -> offsets and grand totals
6. ``mc_word_offsets`` per active brick: each word's first vertex and triangle, and the order
                       in which pass 7 takes the brick's words (by their work: see the shader)
7. ``mc_triangles``    active bricks: triangle indices into the shared vertices, and
                       for each vertex the edge it lies on (a job for pass 8, in a buffer)
8. ``mc_vertices``     one invocation per vertex: position, value and outward normal

Between passes 1 and 2, ``mc_dispatch_args`` turns the active count into the indirect
dispatch sizes of passes 2-4, 6 and 7, so those touch only the bricks whose range
contains the new level (pass 1 and the scans still visit every brick, cheaply).
Scratch: 16 bytes per 32-sample word plus 24 per brick (about 0.5 byte per voxel;
0.75 for a moment while the brick ranges are measured), and 4 bytes per vertex for the jobs
(shaders/vertex_jobs.glsl says why they have a buffer of their own).  Read-backs
per extraction: the two totals (8 bytes), which size the outputs, and after the passes
the active-brick count (4 bytes), for the stats.

What the passes read often (the volume, per-word signs, counts and offsets) lives in
images and the case table in a uniform block: on llvmpipe an SSBO load costs 4-6 times
an imageLoad (see shaders/mc_common.glsl).  SSBOs hold the mesh and per-brick lists.
"""
from __future__ import annotations

import time

import moderngl
import numpy as np

from .. import validation
from ..core.case_table import CaseTable, montani_table
from ..core.layout import (
    GROUP_SIZE,
    INDEX_BYTES,
    STORAGE_OFFSET_ALIGNMENT,
    VERTEX_BYTES,
    WORD_BITS,
    ImageUnit,
    StorageBlock,
    divisor_magic,
    job_coordinate_bits,
    volume_texel_format,
)
from .context import current_or_standalone
from .limits import GPULimitError, GpuLimits, plan_extractor
from .mesh import GpuMesh
from .programs import compute_program, dispatch_groups, set_uniforms
from .scan import ExclusiveScan
from .volume_texture import upload_volume, write_volume

__all__ = ["Extractor", "GPULimitError"]

CASE_TABLE_SHIFT = 10
"""The case-table image is 2^10 texels wide (see mc_case_table.glsl)."""


def case_table_image(ctx: moderngl.Context, table: CaseTable) -> moderngl.Texture:
    """`table`'s words (CaseTable.packed_for_gpu) in an r32ui image 2^CASE_TABLE_SHIFT texels wide."""
    words = table.packed_for_gpu()
    width = 1 << CASE_TABLE_SHIFT
    words = np.concatenate([words, np.zeros(-len(words) % width, np.uint32)])
    return ctx.texture((width, len(words) // width), 1, words.tobytes(), dtype="u4")


PASSES = ("mc_row_range", "mc_brick_range", "mc_bricks", "mc_signs", "mc_dispatch_args", "mc_classify",
          "mc_brick_sums", "mc_word_offsets", "mc_triangles", "mc_vertices")


class Extractor:
    """Keeps one volume on the GPU and extracts its isosurface at any level.

    >>> ex = Extractor(volume, spacing=(1, 1, 1), gradient_direction="descent")
    >>> n_vertices, n_triangles = ex.extract(0.5)   # mesh stays in ex.vertex_buffer / ex.index_buffer
    >>> verts, faces, normals, values = ex.read_mesh()

    `volume` is an array, or a `validation.CheckedVolume`, which is taken without scanning it
    again.  Construction is all or nothing: every size limit is checked before anything is
    allocated, and whatever was allocated is released if a later step fails.  `limits`
    overrides the GL implementation's limits (tests lower them to reach the refusals).
    """

    JOB_COMPONENTS = 1
    """uints per vertex job (shaders/vertex_jobs.glsl): the cubes' (word id, axis, bit) is one."""

    _run_list: moderngl.Buffer | None = None
    """A large mesh's per-run brick list (`_run_bricks`), made when first needed."""
    _volume: moderngl.Texture3D | None = None
    """The volume image (None once released: gpu_bytes reads 0)."""

    def __init__(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                 ctx: moderngl.Context | None = None, table: CaseTable | None = None,
                 limits: GpuLimits | None = None):
        checked = validation.check_volume(volume)
        self.spacing = validation.as_spacing(spacing)
        self.descent = validation.as_gradient_direction(gradient_direction)
        self.shape = checked.data.shape
        self.value_range = checked.value_range
        self.ctx = ctx or current_or_standalone()
        self.table = table or montani_table()
        if WORD_BITS * self.table.max_triangles > 255:  # a word's triangle count has 8 bits (mc_common.glsl)
            raise ValueError(f"a case table with up to {self.table.max_triangles} triangles per cell does not fit "
                             f"the per-word counts; at most {255 // WORD_BITS} can")
        self.plan = plan_extractor(self.shape, limits or GpuLimits.of(self.ctx))  # refuses before allocating
        self._set_grid_uniforms()

        self._texel_format = volume_texel_format(checked.data.dtype)
        _, volume_format, volume_image = self._texel_format
        self.volume_defines = {"VOLUME_FORMAT": volume_format, "VOLUME_IMAGE": volume_image}  # for other passes
        defines = {"MAX_TRIANGLES_PER_CELL": f"{self.table.max_triangles}u",  # the layout's come with every program
                   "CASE_TABLE_SHIFT": f"{CASE_TABLE_SHIFT}u", **self.volume_defines}
        if self._job_bits is not None:  # vertex jobs hold their sample's coordinates (mc_common.glsl)
            defines["JOB_COORDINATES"] = 1
        self._passes = {name: compute_program(self.ctx, f"{name}.comp", defines) for name in PASSES}

        self.n_vertices = 0
        self.n_triangles = 0
        self.active_bricks = 0
        self.level: float | None = None
        self.last_extract_ms = 0.0  # wall time of extract(), read-back included
        self.last_gpu_ms = 0.0  # GPU time of its passes, by GL timer queries (llvmpipe reports ~0)
        self._owned: list = []  # every GL object allocated here, released together
        self.vertex_buffer = self.index_buffer = self.vertex_jobs = None  # grown by _ensure_output, not in _owned
        self._scan: ExclusiveScan | None = None
        try:
            self._allocate(checked.data)
            self._measure_brick_ranges()
            self.value_range = self._value_range(checked)
        except BaseException:
            self.release()
            raise

    # -- set-up -----------------------------------------------------------------------------

    def _set_grid_uniforms(self) -> None:
        # What every pass is told about the grid, the same at every level (the division constants too).
        self._grid_uniforms = dict(
            u_dims=self.shape, u_words=self.plan.words_per_row, u_bricks=self.plan.bricks,
            u_brick_count=self.plan.brick_count, u_spacing=self.spacing, u_word_shift=self.plan.word_shift,
            u_div_words=divisor_magic(self.plan.words_per_row), u_div_rows=divisor_magic(self.shape[1]),
            u_div_bricks_j=divisor_magic(self.plan.bricks[1]))
        self._job_bits = job_coordinate_bits(self.shape)
        if self._job_bits is not None:
            self._grid_uniforms["u_job_bits"] = self._job_bits

    def fits(self, volume) -> bool:
        """Whether `reload` can take `volume` (an array or a CheckedVolume): the same shape, and samples
        the volume image holds in the same format."""
        data = volume.data if isinstance(volume, validation.CheckedVolume) else np.asarray(volume)
        return data.shape == self.shape and volume_texel_format(data.dtype) == self._texel_format

    def reload(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent") -> None:
        """Take a new volume of the same shape and sample format (`fits`) into this extractor's GL objects:
        the volume image is written in place and the brick ranges measured again, nothing is allocated
        (new storage costs llvmpipe a zeroing pass and the OS a page fault per page: on a 256^3 float32
        volume, 26 of the one-shot call's ~90 ms, and the mesh buffers grow from nothing again).  The
        last mesh is dropped.  A volume that does not fit raises ValueError and changes nothing."""
        checked = validation.check_volume(volume)
        spacing = validation.as_spacing(spacing)
        descent = validation.as_gradient_direction(gradient_direction)
        if not self.fits(checked):
            raise ValueError(f"a {checked.data.dtype} volume of shape {checked.data.shape} does not fit this "
                             f"extractor's {self.plan.dims_text} image; make a new Extractor for it")
        self.n_vertices = self.n_triangles = self.active_bricks = 0
        self.level = None
        self.spacing, self.descent, self.value_range = spacing, descent, checked.value_range
        self._set_grid_uniforms()
        write_volume(self._volume, checked.data, self.plan)
        self._measure_brick_ranges()
        self.value_range = self._value_range(checked)

    @property
    def brick_count(self) -> int:
        return self.plan.brick_count

    # Read-only views for passes that share this resident volume (app/tetra_extractor.py, app/smoothing.py).
    @property
    def volume_texture(self) -> moderngl.Texture3D:
        """The resident volume image (see mc_common.glsl); `volume_defines` say its format."""
        return self._volume

    @property
    def brick_ranges(self) -> moderngl.Buffer:
        return self._brick_ranges

    @property
    def grid_uniforms(self) -> dict:
        """The grid uniforms of mc_common.glsl (not the level), for passes that include it."""
        return dict(self._grid_uniforms)

    def _own(self, gl_object):
        self._owned.append(gl_object)
        return gl_object

    def _allocate(self, field: np.ndarray) -> None:
        ctx, plan = self.ctx, self.plan
        self._volume = self._own(upload_volume(ctx, field, plan))
        self._sign_words = self._own(ctx.texture(plan.word_image_size, 1, dtype="u4"))
        self._word_counts = self._own(ctx.texture(plan.word_image_size, 1, dtype="u4"))
        self._word_offsets = self._own(ctx.texture(plan.word_image_size, 2, dtype="u4"))  # (first vertex, triangle)
        sizes = plan.storage_elements()
        self._brick_vertex_offsets = self._storage(sizes["brick vertex offsets"])
        self._brick_triangle_offsets = self._storage(sizes["brick triangle offsets"])
        self._brick_ranges = self._storage(sizes["brick ranges"])
        self._active_bricks = self._storage(sizes["active bricks"])
        self._brick_states = self._storage(sizes["brick states"])
        self._brick_states.clear()  # 0: the sign words hold nothing known (mc_bricks.comp)
        self._non_finite = self._storage(1)  # set by mc_row_range.comp: a NaN or infinite sample
        self._dispatch_args = self._own(ctx.buffer(reserve=24))  # groups per active brick, then per 64 bricks
        self._case_table = self._own(case_table_image(ctx, self.table))
        self._scan = ExclusiveScan(ctx)
        self.vertex_buffer = ctx.buffer(reserve=VERTEX_BYTES)
        self.index_buffer = ctx.buffer(reserve=INDEX_BYTES)
        self.vertex_jobs = ctx.buffer(reserve=self.job_record_bytes)
        # Two queries: one around counting, one around output, so the CPU's read-back of the
        # totals between them is not counted as GPU time.
        self._timers = (ctx.query(time=True), ctx.query(time=True))

    def _storage(self, elements: int) -> moderngl.Buffer:
        """A work buffer; plan_extractor has already checked its size against the limit."""
        return self._own(self.ctx.buffer(reserve=max(elements, 1) * 4))

    def _bind_images(self) -> None:
        self._volume.bind_to_image(ImageUnit.VOLUME, read=True, write=False)
        self._sign_words.bind_to_image(ImageUnit.SIGN_WORDS, read=True, write=True)
        self._word_counts.bind_to_image(ImageUnit.WORD_COUNTS, read=True, write=True)
        self._word_offsets.bind_to_image(ImageUnit.WORD_OFFSETS, read=True, write=True)
        self._bind_case_table()

    def _bind_case_table(self) -> None:
        self._case_table.bind_to_image(ImageUnit.CASE_TABLE, read=True, write=False)  # see mc_case_table.glsl

    @property
    def job_record_bytes(self) -> int:
        return 4 * self.JOB_COMPONENTS

    def _ensure_output(self, n_vertices: int, n_triangles: int) -> None:
        """Grow the mesh buffers and the vertex-job buffer to fit (by half again, so dragging the slider
        rarely reallocates).  A failed allocation leaves an empty mesh (a buffer may already have been
        replaced) and an extractor that can extract again.

        The buffers may outgrow one storage block: the passes then write them a window at a time."""
        for attr, needed in (("vertex_buffer", n_vertices * VERTEX_BYTES),
                             ("index_buffer", n_triangles * INDEX_BYTES),
                             ("vertex_jobs", n_vertices * self.job_record_bytes)):
            buf = getattr(self, attr)
            held = 0 if buf is None else buf.size  # None: an earlier allocation failed
            if held < needed:
                size = max(needed, int(held * 1.5))
                if buf is not None:
                    buf.release()
                setattr(self, attr, None)  # released: a failing allocation below must not release it twice
                try:
                    setattr(self, attr, self.ctx.buffer(reserve=size))
                except moderngl.Error as exc:
                    self.n_vertices = self.n_triangles = 0  # an empty mesh, in a small buffer where one can be had
                    self.level = None
                    try:
                        setattr(self, attr, self.ctx.buffer(reserve=VERTEX_BYTES))
                    except moderngl.Error:
                        pass
                    raise GPULimitError(
                        f"the mesh at this level ({n_vertices} vertices, {n_triangles} triangles) needs a "
                        f"{size / 2**20:.1f} MiB buffer that this GPU could not allocate ({exc}); pick another "
                        "level, crop or downsample the volume, or use backend='cpu'") from None

    # -- extraction -------------------------------------------------------------------------

    def _set_common_uniforms(self, level: float) -> None:
        sign = 1.0 if self.descent else -1.0
        values = dict(self._grid_uniforms, u_level=float(np.float32(sign * level)), u_sign=sign)
        for program in self._passes.values():
            set_uniforms(program, **values)

    def _bind(self, *slots: tuple[int, moderngl.Buffer]) -> None:
        for binding, buffer in slots:
            buffer.bind_to_storage_buffer(binding)

    def _measure_brick_ranges(self) -> None:
        """Each brick's value range, via each word's row range (a buffer freed afterwards)."""
        word_count = self.plan.word_count
        self._set_common_uniforms(0.0)
        set_uniforms(self._passes["mc_row_range"], u_word_count=word_count)
        self._bind_images()
        row_ranges = self.ctx.buffer(reserve=self.plan.storage_elements()["row ranges"] * 4)
        self._non_finite.clear()
        try:
            self._bind((StorageBlock.ROW_RANGES, row_ranges), (StorageBlock.BRICK_RANGES, self._brick_ranges),
                       (StorageBlock.NON_FINITE, self._non_finite))
            dispatch_groups(self._passes["mc_row_range"], -(-word_count // GROUP_SIZE))
            self.ctx.memory_barrier()
            dispatch_groups(self._passes["mc_brick_range"], -(-self.brick_count // GROUP_SIZE))
            self.ctx.memory_barrier()
        finally:
            row_ranges.release()

    def _value_range(self, checked) -> tuple[float, float]:
        """`checked`'s value range: its own, or for a volume whose values were not scanned
        (validation.check_volume(scan_values=False)) the brick ranges' union, after the row-range
        pass found no NaN or infinite sample; where it found one, check_volume's error."""
        if checked.value_range is not None:
            return checked.value_range
        if np.frombuffer(self._non_finite.read(4), np.uint32)[0]:
            checked = validation.check_volume(checked.data)  # raises, naming the first bad sample
            return checked.value_range
        ranges = np.frombuffer(self._brick_ranges.read(8 * self.brick_count), np.float32).reshape(-1, 2)
        return float(ranges[:, 0].min()), float(ranges[:, 1].max())

    def _run_over_active_bricks(self, name: str, per_brick: bool = False) -> None:
        """A work group per active brick (an invocation per word), or an invocation per active brick."""
        self._passes[name].run_indirect(self._dispatch_args, offset=12 if per_brick else 0)
        self.ctx.memory_barrier()

    def extract(self, level: float) -> tuple[int, int]:
        """Extract the surface at `level` into vertex_buffer/index_buffer; returns (vertices, triangles)."""
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
                   (StorageBlock.ACTIVE_BRICKS, self._active_bricks), (StorageBlock.BRICK_RANGES, self._brick_ranges),
                   (StorageBlock.DISPATCH_ARGS, self._dispatch_args), (StorageBlock.BRICK_STATES, self._brick_states))
        dispatch_groups(self._passes["mc_bricks"], -(-(self.brick_count + 1) // GROUP_SIZE))
        self.ctx.memory_barrier()
        dispatch_groups(self._passes["mc_dispatch_args"], 1)
        self.ctx.memory_barrier()
        self._run_over_active_bricks("mc_signs")
        self._run_over_active_bricks("mc_classify")
        self._run_over_active_bricks("mc_brick_sums", per_brick=True)

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
        self._run_over_active_bricks("mc_word_offsets", per_brick=True)
        triangles, vertices = self._passes["mc_triangles"], self._passes["mc_vertices"]
        for (window, job_slots), run_dispatches in zip(runs, dispatches):
            # Each run writes the triangles in its window of the index buffer (usually the only one)
            # and the vertex jobs of the words whose triangles start there (triangle_runs.glsl), into
            # the window of the job buffer that holds their vertices (vertex_jobs.glsl).
            self._bind_window(StorageBlock.MESH_INDICES, self.index_buffer, window, INDEX_BYTES)
            for bricks, jobs in run_dispatches:
                self._bind_window(StorageBlock.VERTEX_JOBS, self.vertex_jobs, jobs, self.job_record_bytes)
                set_uniforms(triangles, u_triangle_window=window, u_job_slots=job_slots, u_job_first=jobs[0])
                if bricks is None:
                    self._run_over_active_bricks("mc_triangles")
                    continue
                self._run_list.write(np.concatenate([[len(bricks)], bricks]).astype(np.uint32))
                # In the active list's place (mc_active_bricks.glsl).
                self._run_list.bind_to_storage_buffer(StorageBlock.ACTIVE_BRICKS)
                dispatch_groups(triangles, len(bricks))
                self.ctx.memory_barrier()
        for window in self.plan.windows(n_vertices, VERTEX_BYTES, self.job_record_bytes):
            self._bind_window(StorageBlock.MESH_VERTICES, self.vertex_buffer, window, VERTEX_BYTES)
            self._bind_window(StorageBlock.VERTEX_JOBS, self.vertex_jobs, window, self.job_record_bytes)
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

    @property
    def mesh(self) -> GpuMesh:
        """The last extraction, in this extractor's buffers (valid until the next extract or release)."""
        return GpuMesh(self.vertex_buffer, self.index_buffer, self.n_vertices, self.n_triangles)

    def read_mesh(self):
        """The last extraction as numpy arrays: verts, faces, normals, values (skimage's layout)."""
        return self.mesh.read()

    def scratch_bytes(self) -> int:
        """GPU memory beyond the volume texture and the mesh buffers (the vertex-job buffer included)."""
        images = sum(t.width * t.height * t.components * 4 for t in self._word_images())
        return images + self.job_bytes() + sum(b.size for b in self._scratch_buffers()) + self._scan.scratch_bytes()

    def gpu_bytes(self) -> int:
        """All the GL memory this extractor holds: the volume image, scratch_bytes and the mesh buffers."""
        if self._volume is None:
            return 0
        image = self._volume
        volume = image.width * image.height * image.depth * image.components * int(image.dtype[1:])
        meshes = sum(b.size for b in (self.vertex_buffer, self.index_buffer) if b is not None)
        return volume + self.scratch_bytes() + meshes

    def job_bytes(self) -> int:
        """The vertex-job buffer's share of scratch_bytes: JOB_COMPONENTS uints per vertex, grown with the mesh."""
        return 0 if self.vertex_jobs is None else self.vertex_jobs.size

    def _word_images(self) -> tuple[moderngl.Texture, ...]:
        """The images scratch_bytes counts: the per-word ones and the case table."""
        return (self._sign_words, self._word_counts, self._word_offsets, self._case_table)

    def _scratch_buffers(self) -> tuple[moderngl.Buffer, ...]:
        return (self._brick_vertex_offsets, self._brick_triangle_offsets, self._brick_ranges, self._active_bricks,
                self._brick_states, self._non_finite, self._dispatch_args)

    def release(self) -> None:
        """Free every GL object this extractor made; safe to call twice, or on a half-built one."""
        for obj in (*self._owned, self.vertex_buffer, self.index_buffer, self.vertex_jobs):
            if obj is not None:
                obj.release()
        self._owned.clear()
        self.vertex_buffer = self.index_buffer = self.vertex_jobs = self._run_list = self._volume = None
        if self._scan is not None:
            self._scan.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
