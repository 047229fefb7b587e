"""The compute-shader extractor on a real EGL context, checked against the numpy reference and facts."""
import numpy as np
import pytest
from support.mesh_checks import (
    assert_clean_geometry,
    assert_closed_manifold,
    assert_holes_only_on_the_border,
    assert_same_mesh,
    sign_changing_edges,
    signed_volume,
)

from isoscope.core.layout import VERTEX_BYTES
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.gpu.cubes import Extractor
from isoscope.gpu.scan import ExclusiveScan

RNG = np.random.default_rng(20261122)


@pytest.mark.parametrize("shape", [(2, 2, 2), (300, 300, 2), (17, 5, 33), (3, 2, 65), (2, 31, 32), (6, 4, 97)])
def test_any_grid_size_matches_the_reference(gpu_mesh, shape):
    volume = RNG.normal(size=shape).astype(np.float32)
    level = 0.05
    gpu = gpu_mesh(volume, level)
    assert_same_mesh(gpu, marching_cubes_reference(volume, level))
    assert len(gpu[0]) == sign_changing_edges(volume, level)


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_ties_and_spacing_match_the_reference(gpu_mesh, direction):
    volume = RNG.integers(-2, 3, size=(19, 23, 40)).astype(np.float32)  # about a fifth of samples tie
    spacing = (0.5, 2.0, 1.25)
    gpu = gpu_mesh(volume, 0.0, spacing=spacing, gradient_direction=direction)
    cpu = marching_cubes_reference(volume, 0.0, spacing, direction == "descent")
    assert_same_mesh(gpu, cpu)
    assert len(gpu[0]) == sign_changing_edges(volume, 0.0, direction == "descent")


def test_output_is_identical_from_run_to_run(gl_ctx):
    volume = RNG.normal(size=(40, 33, 70)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.2)
        first = [a.copy() for a in ex.read_mesh()]
        ex.extract(-0.5)
        ex.extract(0.2)
        second = ex.read_mesh()
    for a, b in zip(first, second):
        assert a.tobytes() == b.tobytes()


def test_nothing_is_written_past_the_mesh(gl_ctx):
    """Fill the output buffers with a sentinel, re-extract a smaller mesh, and find the tail untouched."""
    volume = RNG.normal(size=(30, 30, 30)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        big_vertices = ex.n_vertices
        sentinel_v = b"\xab" * ex.vertex_buffer.size
        sentinel_i = b"\xcd" * ex.index_buffer.size
        ex.vertex_buffer.write(sentinel_v)
        ex.index_buffer.write(sentinel_i)
        ex.extract(2.0)
        assert 0 < ex.n_vertices < big_vertices
        tail_v = ex.vertex_buffer.read()[ex.n_vertices * VERTEX_BYTES:]
        tail_i = ex.index_buffer.read()[ex.n_triangles * 12:]
        assert tail_v == sentinel_v[: len(tail_v)] and len(tail_v) > 0
        assert tail_i == sentinel_i[: len(tail_i)] and len(tail_i) > 0
        faces = ex.read_mesh()[1]
        assert faces.min() >= 0 and faces.max() < ex.n_vertices


def test_outputs_grow_with_the_mesh_and_nothing_is_dropped(gl_ctx):
    volume = RNG.normal(size=(48, 48, 48)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        for level in (3.0, 1.0, 0.0):  # the mesh grows at each level
            ex.extract(level)
            cpu = marching_cubes_reference(volume, level)
            assert (ex.n_vertices, ex.n_triangles) == (len(cpu[0]), len(cpu[1]))
            assert ex.vertex_buffer.size >= ex.n_vertices * VERTEX_BYTES


def test_scan_is_exact_well_past_2_to_the_24(gl_ctx):
    count = (1 << 24) + (1 << 20) + 7
    values = RNG.integers(0, 200, size=count, dtype=np.uint32)
    buf = gl_ctx.buffer(values.tobytes())
    scan = ExclusiveScan(gl_ctx)
    scan(buf, count)
    got = np.frombuffer(buf.read(), np.uint32)
    expected = np.zeros(count, np.uint64)
    np.cumsum(values[:-1], dtype=np.uint64, out=expected[1:])
    np.testing.assert_array_equal(got, expected.astype(np.uint32))
    buf.release()
    scan.release()


def test_empty_level_gives_an_empty_mesh(gl_ctx):
    volume = RNG.normal(size=(9, 9, 9)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        assert ex.extract(float(volume.min())) == (0, 0)  # every sample is inside: no surface
        verts, faces, normals, values = ex.read_mesh()
        assert verts.shape == (0, 3) and faces.shape == (0, 3)


def test_closed_surfaces_from_random_padded_fields_are_watertight(gpu_mesh):
    for _ in range(6):
        shape = RNG.integers(3, 24, size=3)
        volume = np.pad(RNG.integers(-1, 2, size=shape).astype(np.float32), 1, constant_values=-1.0)
        verts, faces, _, _ = gpu_mesh(volume, 0.0)
        assert_closed_manifold(faces)
        assert_clean_geometry(verts, faces)
        assert signed_volume(verts, faces) > 0


def test_open_surface_holes_only_at_the_volume_border(gpu_mesh):
    volume = RNG.normal(size=(20, 25, 30)).astype(np.float32)
    verts, faces, _, _ = gpu_mesh(volume, 0.0)
    assert_holes_only_on_the_border(verts, faces, volume.shape)


@pytest.mark.parametrize("shape", [(64, 64, 64), (40, 56, 96), (33, 17, 250), (9, 130, 64), (24, 24, 64)])
def test_scratch_stays_under_one_byte_per_voxel(gl_ctx, shape):
    # GPU memory beyond the volume and the mesh stays under a byte per voxel (for rows
    # of a word or more: a row shorter than 32 samples still takes a whole word per scratch array),
    # besides the vertex jobs: 4 bytes per vertex (an eighth of the vertex buffer's 32, half again while
    # it grows).
    volume = RNG.normal(size=shape).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        assert ex.n_triangles > 0
        jobs = ex.job_bytes()
        assert ex.scratch_bytes() - jobs < volume.size, (ex.scratch_bytes() - jobs) / volume.size
        assert 4 * ex.n_vertices <= jobs <= 4 * 1.5 * ex.n_vertices


def test_vertex_jobs_hold_coordinates_where_they_fit_in_32_bits():
    from isoscope.core.layout import job_coordinate_bits
    assert job_coordinate_bits((197, 233, 189)) == (8, 8)  # 8 + 8 + 8 bits of i, j, k and 2 of the axis
    assert job_coordinate_bits((2, 2, 2)) == (1, 1)
    assert job_coordinate_bits((1024, 1024, 1024)) == (10, 10)  # 32 bits exactly
    assert job_coordinate_bits((1025, 1024, 1024)) is None  # 33: the word-id encoding instead


@pytest.mark.parametrize("shape", [(17, 5, 33), (6, 70, 97)])
def test_word_id_vertex_jobs_give_the_same_mesh(gl_ctx, monkeypatch, shape):
    """The encoding for grids too large for coordinates in a job (mc_jobs.glsl), forced on a small one."""
    import isoscope.gpu.resident as resident_module
    volume = RNG.normal(size=shape).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as packed:
        packed.extract(0.1)
        expected = [a.copy() for a in packed.read_mesh()]
        assert packed.resident.job_bits is not None
    monkeypatch.setattr(resident_module, "job_coordinate_bits", lambda shape: None)
    with Extractor(volume, ctx=gl_ctx) as by_word:
        assert by_word.resident.job_bits is None
        by_word.extract(0.1)
        for a, b in zip(expected, by_word.read_mesh()):
            assert a.tobytes() == b.tobytes()
    assert_same_mesh(expected, marching_cubes_reference(volume, 0.1))


def test_reading_a_mesh_by_records_or_by_fields_gives_the_same_arrays(gl_ctx, monkeypatch):
    """GpuMesh.read copies each field out of the mapped buffer on a software renderer, and reads the
    records once and splits them elsewhere (mesh._read_fields): both give the same contiguous arrays."""
    import isoscope.gpu.mesh as mesh_module
    volume = RNG.normal(size=(20, 18, 37)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.3)
        by_fields = ex.read_mesh()
        monkeypatch.setattr(mesh_module, "is_software_renderer", lambda ctx: False)   # as on a GPU
        by_records = ex.read_mesh()
    for a, b in zip(by_fields, by_records):
        assert a.dtype == b.dtype and a.flags.c_contiguous and b.flags.c_contiguous
        assert a.tobytes() == b.tobytes()
    assert_same_mesh(by_fields, marching_cubes_reference(volume, 0.3))


def test_use_after_release_says_so_in_one_line(gl_ctx):
    import isoscope
    volume = np.random.default_rng(3).random((12, 12, 12), dtype=np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        assert ex.extract(0.5)[1] > 0
    for use in (lambda: ex.extract(0.5), ex.read_mesh):   # was AttributeError: 'NoneType' ... bind_to_image
        with pytest.raises(isoscope.IsoscopeError, match="released.*make a new one"):
            use()
