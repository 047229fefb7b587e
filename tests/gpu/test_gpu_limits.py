"""Volumes at and past the GL limits the extractor depends on: the 3-D texture size, and the
row padding it does itself (4 samples per RGBA texel along axis 2)."""
import os

import moderngl
import numpy as np
import pytest
from support.mesh_checks import assert_same_mesh

import isoscope.gpu.volume_texture as volume_texture
from isoscope.core.layout import INDEX_BYTES, STORAGE_OFFSET_ALIGNMENT, VERTEX_BYTES
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.gpu.cubes import Extractor, GPULimitError
from isoscope.gpu.limits import GpuLimits, plan_extractor
from isoscope.gpu.passes import run_dispatches
from isoscope.gpu.resident import ResidentVolume

RNG = np.random.default_rng(7)


def texture_limit(ctx) -> int:
    return int(ctx.info["GL_MAX_3D_TEXTURE_SIZE"])


def test_rows_padded_to_whole_texels_go_up_in_slabs(gpu_mesh, monkeypatch):
    # 13 samples per row are padded to 16; a 1-byte slab budget forces one upload per plane.
    monkeypatch.setattr(volume_texture, "UPLOAD_SLAB_BYTES", 1)
    volume = RNG.normal(size=(5, 7, 13)).astype(np.float32)
    assert_same_mesh(gpu_mesh(volume, 0.1), marching_cubes_reference(volume, 0.1))


def test_axis_2_may_be_four_times_the_texture_limit(gl_ctx, gpu_mesh):
    n2 = texture_limit(gl_ctx) + 5  # more samples than one texture axis holds, padded to whole texels
    volume = RNG.normal(size=(2, 3, n2)).astype(np.float32)
    assert_same_mesh(gpu_mesh(volume, 0.0), marching_cubes_reference(volume, 0.0))


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_volume_past_the_texture_limit_is_refused_with_the_fix(gl_ctx, axis):
    shape = [2, 2, 2]
    shape[axis] = texture_limit(gl_ctx) * (4 if axis == 2 else 1) + 1
    volume = np.zeros(shape, np.float32)
    with pytest.raises(GPULimitError) as caught:
        Extractor(volume, ctx=gl_ctx)
    message = str(caught.value)
    assert "\n" not in message
    assert "x".join(map(str, shape)) in message and "3-D texture limit" in message
    assert "downsample" in message


def resident_bytes() -> int:
    """This process's resident memory: llvmpipe keeps textures and buffers in it."""
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def ramp(n=256) -> np.ndarray:
    """A 64 MiB float32 volume whose upload is easy to see in the process's memory."""
    return np.broadcast_to(np.arange(n, dtype=np.float32), (n, n, n)).copy()


def test_a_volume_past_the_storage_block_limit_is_refused_before_anything_is_allocated(gl_ctx):
    volume = ramp()
    real = GpuLimits.of(gl_ctx)
    # The set-up's row ranges take 8 bytes per 32-sample word: 4 MiB here, over a 2 MiB limit.
    limits = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 2 << 20)
    Extractor(volume[:8], ctx=gl_ctx, limits=limits).release()  # a small one fits: warm-up
    before = resident_bytes()
    for _ in range(8):
        with pytest.raises(GPULimitError, match="row ranges buffer, above this GPU's 2 MiB storage-block limit"):
            Extractor(volume, ctx=gl_ctx, limits=limits)
    assert resident_bytes() - before < 32 << 20, "failed constructions kept GPU memory"


def test_a_failure_late_in_the_set_up_releases_what_was_allocated(gl_ctx, monkeypatch):
    volume = ramp()
    Extractor(volume, ctx=gl_ctx).release()  # warm-up: shaders compiled, allocator primed
    before = resident_bytes()

    def fail(self, checked):
        raise moderngl.Error("the last set-up step failed")
    monkeypatch.setattr(ResidentVolume, "_measure", fail)
    for _ in range(8):
        with pytest.raises(moderngl.Error):
            Extractor(volume, ctx=gl_ctx)
    assert resident_bytes() - before < 32 << 20, "a half-built extractor kept its texture and buffers"


@pytest.mark.parametrize("block_kib", [16, 41])
def test_a_mesh_larger_than_one_storage_block_is_written_a_window_at_a_time(gl_ctx, block_kib):
    volume = RNG.normal(size=(30, 33, 45)).astype(np.float32)  # noise: a mesh of tens of thousands of triangles
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, block_kib << 10)
    with Extractor(volume, ctx=gl_ctx, limits=small) as ex:
        n_vertices, n_triangles = ex.extract(0.1)
        assert len(ex.plan.windows(n_vertices, VERTEX_BYTES)) > 10
        assert len(ex.plan.triangle_runs(n_triangles)) > 10 and n_triangles * 12 > 10 * (block_kib << 10)
        windowed = ex.read_mesh()
        ex.extract(0.3)   # and again at another level, into the same (grown) buffers
        windowed_again = ex.read_mesh()
    assert_same_mesh(windowed, marching_cubes_reference(volume, 0.1))
    assert_same_mesh(windowed_again, marching_cubes_reference(volume, 0.3))


def test_windows_cover_every_record_once_at_aligned_offsets(gl_ctx):
    real = GpuLimits.of(gl_ctx)
    plan = plan_extractor((8, 8, 40), GpuLimits(real.max_3d_texture_size, real.max_texture_size, 10_000))
    for count, record in ((0, 12), (1, 32), (12_345, 12), (7_777, 32)):
        windows = plan.windows(count, record)
        covered = [i for first, n in windows for i in range(first, first + n)]
        assert covered == list(range(count))
        assert all(first * record % STORAGE_OFFSET_ALIGNMENT == 0 and n * record <= 10_000 for first, n in windows)


@pytest.mark.parametrize("count", [0, 1, 833, 12_345])
def test_each_triangle_run_writes_its_window_and_every_word_writes_its_jobs_in_one_run(gl_ctx, count):
    real = GpuLimits.of(gl_ctx)
    plan = plan_extractor((8, 8, 40), GpuLimits(real.max_3d_texture_size, real.max_texture_size, 10_000))
    runs = plan.triangle_runs(count)
    assert [window for window, _ in runs] == plan.windows(count, INDEX_BYTES)
    # The job slots tile [0, 2^32) in order: a word's first triangle slot (any uint32) is in one run's.
    starts = [start for _, (start, _) in runs]
    ends = [end for _, (_, end) in runs]
    assert starts[0] == 0 and ends[-1] == 2**32 - 1 and starts[1:] == ends[:-1]
    assert all(start == window[0] for (window, (start, _)) in runs[1:])


@pytest.mark.parametrize("active", [0, 5, 1000, 65_535, 65_536, 70_001, 131_071])
def test_the_active_brick_dispatch_takes_every_brick_once_and_folds_evenly(gl_ctx, tmp_path, monkeypatch, active):
    # mc_dispatch_args.comp folds the active bricks' work groups into 2-D past 65,535; each brick must be
    # taken by exactly one group, and the fold must stay even (65,536 as 65,535 x 2 added 65,534 empty
    # groups, which are not free on llvmpipe).
    from isoscope.core.layout import MAX_GROUPS_PER_DIMENSION
    from isoscope.gpu.programs import compute_program
    from isoscope.resources import shaders_dir
    for path in shaders_dir().iterdir():
        (tmp_path / path.name).write_text(path.read_text())
    (tmp_path / "probe.comp").write_text(
        '#version 430\nlayout(local_size_x = 1) in;\n#include "mc_common.glsl"\n#include "mc_active_bricks.glsl"\n'
        "layout(std430, binding = 0) buffer Hits { uint hits[]; };\n"
        "void main() { uint brick; if (active_brick(brick)) atomicAdd(hits[brick], 1u); }\n")
    monkeypatch.setattr("isoscope.resources.shaders_dir", lambda: tmp_path)
    volume = {"VOLUME_FORMAT": "rgba32f", "VOLUME_IMAGE": "image3D"}
    probe, args = compute_program(gl_ctx, "probe.comp", volume), compute_program(gl_ctx, "mc_dispatch_args.comp")
    buffers = [gl_ctx.buffer(np.concatenate([[active], np.arange(active)]).astype(np.uint32).tobytes()),
               gl_ctx.buffer(reserve=24), gl_ctx.buffer(reserve=4 * max(active, 1))]
    listed, dispatch, hits = buffers
    try:
        hits.clear()
        listed.bind_to_storage_buffer(7)
        dispatch.bind_to_storage_buffer(9)
        args.run(1)
        gl_ctx.memory_barrier()
        hits.bind_to_storage_buffer(0)
        probe.run_indirect(dispatch)
        gl_ctx.memory_barrier()
        taken = np.frombuffer(hits.read(), np.uint32)[:active]
        x, y, _ = np.frombuffer(dispatch.read(12), np.uint32).tolist()
    finally:
        for buffer in buffers:
            buffer.release()
    assert (taken == 1).all(), f"{int((taken == 0).sum())} bricks missed, {int((taken > 1).sum())} taken twice"
    assert x <= MAX_GROUPS_PER_DIMENSION and active <= x * y < active + max(y, 1)


@pytest.mark.parametrize("block_kib", [24, 64])
def test_each_run_of_a_large_mesh_takes_only_the_bricks_with_work_in_it(gl_ctx, block_kib):
    # PassRunner.dispatches: every brick with vertices or triangles is in the runs its triangles meet
    # and in the one run that writes its words' vertex jobs, and in no other (the mesh itself is checked
    # against the reference above).
    volume = RNG.normal(size=(30, 33, 45)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, block_kib << 10)
    with Extractor(volume, ctx=gl_ctx, limits=small) as ex:
        n_vertices, n_triangles = ex.extract(0.1)
        runs = ex.plan.triangle_runs(n_triangles)
        dispatches = ex.passes.dispatches(ex.scratch, runs, n_vertices)
        lists = [np.concatenate([bricks for bricks, _ in run]) for run in dispatches]
        # and each dispatch's job window starts aligned and fits one block
        for run in dispatches:
            for _, (first, span) in run:
                assert first * 4 % 256 == 0 and span * 4 <= block_kib << 10
        count = ex.brick_count + 1
        firsts = np.frombuffer(ex.scratch.brick_triangle_offsets.read(4 * count), np.uint32).astype(np.int64)
        vertex_firsts = np.frombuffer(ex.scratch.brick_vertex_offsets.read(4 * count), np.uint32)
        for run in dispatches:  # and holds its bricks' vertices
            for bricks, (first, span) in run:
                assert first <= vertex_firsts[bricks[0]] and vertex_firsts[bricks[-1] + 1] <= first + span
    assert len(runs) > 3 and len(lists) == len(runs)
    busy = np.flatnonzero((np.diff(firsts) > 0) | (np.diff(vertex_firsts) > 0))
    taken = np.concatenate(lists)
    assert set(taken.tolist()) == set(busy.tolist())  # every busy brick, and only those
    def run_of(slot):  # the run whose job slots hold a triangle slot
        return next(r for r, (_, (s, e)) in enumerate(runs) if s <= slot < e)
    for b in busy:
        meets = {r for r, ((first, n), _) in enumerate(runs) if firsts[b] < first + n and first < firsts[b + 1]}
        # needed: its triangles' runs and its first word's job run; allowed besides: the job run of the
        # brick's end (its last words may have no triangle and start at that slot)
        needed, allowed = meets | {run_of(firsts[b])}, {run_of(firsts[b + 1])}
        held = {r for r, bricks in enumerate(lists) if b in bricks}
        assert needed <= held <= needed | allowed, (b, needed, held)


@pytest.mark.parametrize("job_bytes", [4, 8])
def test_run_dispatches_give_each_busy_brick_to_its_runs_in_aligned_job_windows(job_bytes):
    # No GL: bricks' offsets as the scan leaves them (some bricks empty, some with vertices only), the
    # runs of a 24 KiB storage block, and what each run's dispatches take.
    rng = np.random.default_rng(11)
    n = 400
    triangles = rng.integers(0, 60, n) * (rng.random(n) < 0.7)
    vertices = rng.integers(0, 40, n) * (rng.random(n) < 0.8)
    firsts = np.concatenate([[0], np.cumsum(triangles)]).astype(np.int64)
    vertex_firsts = np.concatenate([[0], np.cumsum(vertices)]).astype(np.int64)
    block = 24 << 10
    plan = plan_extractor((8, 8, 40), GpuLimits(16384, 16384, block))
    runs = plan.triangle_runs(int(firsts[-1]))
    dispatches = run_dispatches(runs, firsts, vertex_firsts, block, job_bytes)
    assert len(runs) > 3 and len(dispatches) == len(runs)
    busy = set(np.flatnonzero((triangles > 0) | (vertices > 0)).tolist())
    for ((first_t, count_t), (s, e)), run in zip(runs, dispatches):
        bricks = np.concatenate([b for b, _ in run]) if run else np.zeros(0, int)
        assert np.all(np.diff(bricks) > 0)  # ascending, none twice
        # every busy brick whose triangles meet the window or whose job slots lie in [s, e)
        wanted = {b for b in busy if (firsts[b] < first_t + count_t and first_t < firsts[b + 1])
                  or s <= firsts[b] < e}
        assert wanted <= set(bricks.tolist()) <= busy
        for taken, (first, span) in run:
            assert first * job_bytes % STORAGE_OFFSET_ALIGNMENT == 0 and span * job_bytes <= block
            assert first <= vertex_firsts[taken[0]] and vertex_firsts[taken[-1] + 1] <= first + span
    vertex_firsts[n // 2 + 1:] += block  # one brick with more jobs than a block holds
    with pytest.raises(GPULimitError, match="more vertex jobs than a storage block"):
        run_dispatches(plan.triangle_runs(int(firsts[-1])), firsts, vertex_firsts, block, job_bytes)


def test_a_brick_with_vertices_and_no_triangles_on_a_window_start_writes_its_jobs(gl_ctx):
    # A brick whose words own vertices but no triangle (the grid's last rows) has its words' first
    # triangle slot at the brick's end: where that slot starts a window of triangles, the brick's jobs
    # are that next run's, which must take the brick too.  Block sizes are searched for that case.
    volume = np.random.default_rng(0).normal(size=(30, 33, 45)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.1)
        count = ex.brick_count + 1
        firsts = np.frombuffer(ex.scratch.brick_triangle_offsets.read(4 * count), np.uint32).astype(np.int64)
        vertices = np.frombuffer(ex.scratch.brick_vertex_offsets.read(4 * count), np.uint32).astype(np.int64)
    quiet = [b for b in range(count - 1) if firsts[b] == firsts[b + 1] and vertices[b + 1] > vertices[b]]
    # Index windows hold a multiple of 64 triangles (lcm(12, 256) bytes): blocks of 768 * m bytes.
    sizes = [m for m in range(21, 200) if any(firsts[b] > 0 and firsts[b] % (64 * m) == 0 for b in quiet)][:2]
    assert sizes, "no block size puts such a brick on a window start: the test needs another volume"
    expected = marching_cubes_reference(volume, 0.1)
    for m in sizes:
        small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 768 * m)
        with Extractor(volume, ctx=gl_ctx, limits=small) as ex:
            ex.extract(0.1)
            assert_same_mesh(ex.read_mesh(), expected)


@pytest.mark.parametrize("block", [41 << 10, 100_000, 2**31 - 1])
def test_vertex_windows_start_where_the_vertices_and_their_jobs_can_both_be_bound(gl_ctx, block):
    # The vertex pass binds the same (first, count) window of the vertex buffer (32-byte records) and
    # of the job buffer (4 or 8 bytes): both offsets must be multiples of the storage alignment.
    real = GpuLimits.of(gl_ctx)
    plan = plan_extractor((8, 8, 40), GpuLimits(real.max_3d_texture_size, real.max_texture_size, block))
    for jobs in (4, 8):
        windows = plan.windows(50_000_000, VERTEX_BYTES, jobs)
        assert len(windows) > 1 or block > 50_000_000 * VERTEX_BYTES
        for first, n in windows:
            assert first * VERTEX_BYTES % STORAGE_OFFSET_ALIGNMENT == 0 and first * jobs % STORAGE_OFFSET_ALIGNMENT == 0
            assert n * VERTEX_BYTES <= block
        assert sum(n for _, n in windows) == 50_000_000


def test_a_failed_output_allocation_leaves_an_empty_mesh_and_a_working_extractor(gl_ctx):
    # The third buffer the outputs grow (the vertex jobs) cannot be had: a one-line refusal, an empty
    # mesh (the vertex buffer was already replaced), and the next extraction works.
    volume = RNG.normal(size=(30, 33, 45)).astype(np.float32)
    few = float(np.sort(volume, axis=None)[-4])

    class FailingThird:  # the real context, whose third buffer allocation fails
        def __init__(self, ctx):
            self._ctx, self.calls = ctx, 0

        def __getattr__(self, name):
            return getattr(self._ctx, name)

        def buffer(self, *args, **kwargs):
            self.calls += 1
            if self.calls == 3:
                raise moderngl.Error("out of memory (simulated)")
            return self._ctx.buffer(*args, **kwargs)

    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(few)
        failing = FailingThird(gl_ctx)
        for output in ex.outputs.buffers.values():  # the growable mesh and job buffers (buffers.GrowableBuffer)
            output.ctx = failing
        with pytest.raises(GPULimitError) as refusal:
            ex.extract(0.0)
        assert "\n" not in str(refusal.value) and "could not allocate" in str(refusal.value)
        assert ex.n_vertices == ex.n_triangles == 0 and len(ex.read_mesh()[1]) == 0
        for output in ex.outputs.buffers.values():
            output.ctx = gl_ctx
        ex.extract(0.0)
        assert_same_mesh(ex.read_mesh(), marching_cubes_reference(volume, 0.0))
