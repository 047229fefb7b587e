"""topology="trilinear" on the GPU (isoscope.gpu.trilinear): the numpy specification's mesh, bit for bit.

Faces, positions and values equal the reference's bit for bit; normals too, up to today's: the edge
vertices' normals are the cubes' (within an ulp of numpy's, as ever), and each own vertex's normal is
the reference's arithmetic (`cell_vertex_means`) on the GPU's edge vertices, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
from support.mc33 import MC33, grid, symmetries
from support.mesh_checks import assert_closed_manifold
from support.trilinear_cases import bit_for_bit_cases, closed_noise

import isoscope
from isoscope.cpu.trilinear import cell_vertex_means, marching_cubes_trilinear, trilinear_parts
from isoscope.errors import IsoscopeError
from isoscope.gpu.cubes import Extractor
from isoscope.gpu.limits import GpuLimits
from isoscope.gpu.trilinear import TrilinearExtractor

SPACING = (0.5, 1.0, 2.0)


def assert_the_references_mesh(mesh, volume, level, direction, spacing=SPACING):
    """`mesh` is the numpy specification's: faces, positions, values bit for bit; the edge vertices' normals
    within today's cubes' tolerance, and the own vertices' the reference's arithmetic on them, bit for bit."""
    descent = direction == "descent"
    field = np.asarray(volume, np.float32)
    verts, faces, normals, values = marching_cubes_trilinear(field, level, spacing, descent)
    edge_verts, _, _, _, members = trilinear_parts(field, level, spacing, descent)
    n_edge = len(edge_verts)
    assert len(members) == len(verts) - n_edge
    np.testing.assert_array_equal(mesh[1], faces)
    np.testing.assert_array_equal(mesh[0], verts)
    np.testing.assert_array_equal(mesh[3], values)
    np.testing.assert_allclose(mesh[2][:n_edge], normals[:n_edge], atol=1e-6)
    own = cell_vertex_means(mesh[0][:n_edge], mesh[2][:n_edge], mesh[3][:n_edge], members)
    np.testing.assert_array_equal(mesh[2][n_edge:], own[1])
    return len(members)


@pytest.mark.parametrize("name, volume, level, direction", bit_for_bit_cases(38),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_the_gpu_mesh_is_the_references(gl_ctx, name, volume, level, direction):
    with TrilinearExtractor(volume, SPACING, direction, ctx=gl_ctx) as extractor:
        extractor.extract(level)
        resident = extractor.read_mesh()
    assert_the_references_mesh(resident, volume, level, direction)
    one_shot = isoscope.api.outward_marching_cubes(volume, level, spacing=SPACING, gradient_direction=direction,
                                                   backend="gpu", topology="trilinear")
    for a, b in zip(one_shot, resident):
        np.testing.assert_array_equal(a, b)
    assert len(resident[1]) > 1000


def test_cells_with_vertices_of_their_own_are_among_them(gl_ctx):
    """Enough noise that tubes needing an own vertex occur, so pass 9 is checked, not skipped."""
    volume = np.random.default_rng(5).standard_normal((40, 40, 64)).astype(np.float32)
    with TrilinearExtractor(volume, ctx=gl_ctx) as extractor:
        extractor.extract(0.0)
        mesh = extractor.read_mesh()
    assert assert_the_references_mesh(mesh, volume, 0.0, "descent", (1.0, 1.0, 1.0)) > 0


def test_the_resident_extractor_follows_the_level_and_keeps_the_cubes_apart(gl_ctx):
    volume = closed_noise(3, 24)
    with isoscope.Extractor(volume, backend="gpu", topology="trilinear", ctx=gl_ctx) as extractor, \
            Extractor(volume, ctx=gl_ctx) as cubes:
        assert isinstance(extractor, TrilinearExtractor)
        for level in (0.5, -0.3, 0.0, 0.5):
            counts = extractor.extract(level)
            cubes.extract(level)
            mesh = extractor.read_mesh()
            assert counts == (len(mesh[0]), len(mesh[1]))
            assert_the_references_mesh(mesh, volume, level, "descent", (1.0, 1.0, 1.0))
            assert_closed_manifold(mesh[1])
            today = cubes.read_mesh()
            assert not np.array_equal(today[1], mesh[1])  # the topologies differ on noise
            np.testing.assert_array_equal(today[0], mesh[0][:len(today[0])])  # the same edge vertices


def test_auto_takes_the_gpu_as_for_todays_mesh(gl_ctx):
    volume = closed_noise(4, 12)
    with isoscope.Extractor(volume, topology="trilinear", ctx=gl_ctx) as extractor:
        assert isinstance(extractor, TrilinearExtractor)


def test_a_mesh_past_one_storage_block_is_refused_in_one_line_and_the_last_mesh_kept(gl_ctx):
    volume = np.random.default_rng(2).standard_normal((24, 24, 40)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 64 << 10)
    with TrilinearExtractor(volume, ctx=gl_ctx, limits=small) as extractor:
        extractor.extract(3.0)  # a few vertices near the extremes
        kept = extractor.read_mesh()
        with pytest.raises(IsoscopeError) as caught:
            extractor.extract(0.0)
        assert "\n" not in str(caught.value) and "backend='cpu'" in str(caught.value)
        assert_the_references_mesh(kept, volume, 3.0, "descent", (1.0, 1.0, 1.0))


def test_auto_on_a_gpu_whose_storage_blocks_cannot_hold_the_mesh_makes_it_on_the_cpu(gl_ctx, monkeypatch):
    """Where backend="auto" takes the GPU (graphics hardware) and the trilinear mesh outgrows one storage block,
    a one-shot call gives the compiled CPU extractor's mesh (the same mesh), not a refusal; backend="gpu",
    named, still refuses.  The small block imitates such a GPU (GpuLimits.of is what a context reports)."""
    import isoscope.gpu.context as context
    volume = np.random.default_rng(2).standard_normal((24, 24, 40)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    monkeypatch.setattr(GpuLimits, "of", classmethod(lambda cls, ctx: cls(real.max_3d_texture_size,
                                                                           real.max_texture_size, 64 << 10)))
    monkeypatch.setattr(context, "_one_shot", "gpu")
    with pytest.raises(IsoscopeError, match="backend='cpu'"):
        isoscope.marching_cubes(volume, 0.0, backend="gpu", topology="trilinear")
    mesh = isoscope.marching_cubes(volume, 0.0, topology="trilinear")
    cpu = isoscope.marching_cubes(volume, 0.0, topology="trilinear", backend="cpu")
    for a, b in zip(mesh, cpu):
        np.testing.assert_array_equal(a, b)
    assert len(mesh[1]) > 1000


def test_mc33s_configurations_on_the_gpu_are_the_references(gl_ctx):
    """The 33 hand-built cells of test_mc33_configurations (their rotations, mirror images and swaps, one
    volume a turn), each its own cell two samples apart: the GPU's mesh is the specification's bit for bit
    (whose counts that test checks cell by cell)."""
    turns = [symmetries(grid(values)) for values, _ in MC33.values()]
    for turn in range(0, 96, 7):
        volume = np.full((3 * len(MC33), 2, 2), -1.0, np.float32)   # a plane between cells keeps them apart
        for n, cells in enumerate(turns):
            volume[3 * n: 3 * n + 2] = cells[turn]
        with TrilinearExtractor(volume, ctx=gl_ctx) as extractor:
            extractor.extract(0.0)
            mesh = extractor.read_mesh()
        assert_the_references_mesh(mesh, volume, 0.0, "descent", (1.0, 1.0, 1.0))
