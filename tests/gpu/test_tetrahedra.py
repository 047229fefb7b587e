"""Marching tetrahedra (issue 9): facts about the mesh, and the GPU mesh equal to the numpy reference."""
import itertools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from support.command import isoscope_here
from support.mesh_checks import (
    assert_clean_geometry,
    assert_closed_manifold,
    assert_same_mesh,
    euler_characteristic,
    read_ply,
    signed_volume,
    triangle_areas,
)

import isoscope
from isoscope.core.layout import VERTEX_BYTES
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.tetra import marching_tetrahedra_reference
from isoscope.gpu.cubes import Extractor
from isoscope.gpu.limits import GPULimitError, GpuLimits
from isoscope.gpu.tetra import TetraExtractor
from isoscope.volumes.builtins import BUILTINS

RNG = np.random.default_rng(20261125)
REPO = Path(__file__).resolve().parents[2]


def tetrahedral_grid_crossings(volume, level, descent=True):
    """Edges of the Kuhn-split grid whose ends differ: from each sample to the one d further, for
    the seven non-zero 0/1 offsets d (3 axes, 3 face diagonals, the body diagonal).  Ties are inside."""
    inside = volume >= level if descent else volume <= level
    n = inside.shape
    total = 0
    for d in itertools.product((0, 1), repeat=3):
        if any(d):
            lo = tuple(slice(0, n[a] - d[a]) for a in range(3))
            hi = tuple(slice(d[a], n[a]) for a in range(3))
            total += int(np.count_nonzero(inside[lo] != inside[hi]))
    return total


def outside_padded(volume, outside):
    return np.pad(volume, 1, constant_values=outside).astype(np.float32)


def sphere(n=64, radius=0.6):
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, n)] * 3, indexing="ij")
    return (np.sqrt(x * x + y * y + z * z) - radius).astype(np.float32)


def smooth_noise():
    noise = gaussian_filter(np.random.default_rng(3).normal(size=(40, 36, 44)), 2.5)
    return outside_padded(noise - noise.mean(), noise.min() - noise.mean() - 1)


def integer_plane(n=24):
    """The seed's plane x + 2y - 3z + 1 on an integer grid: many samples exactly 0."""
    x, y, z = np.mgrid[:n, :n, :n].astype(np.float32) - n // 2
    return outside_padded(x + 2 * y - 3 * z + 1, -100.0)


def zero_slab():
    """Plane k = 6 exactly at the level, below it elsewhere: a thin closed slab."""
    k = np.arange(12, dtype=np.float32)
    return outside_padded(np.broadcast_to(-np.abs(k - 6), (10, 11, 12)), -10.0)


def rounded_gyroid():
    t = np.mgrid[:40, :40, :40].astype(np.float64) * (2 * np.pi / 20)
    gyroid = np.sin(t[0]) * np.cos(t[1]) + np.sin(t[1]) * np.cos(t[2]) + np.sin(t[2]) * np.cos(t[0])
    return outside_padded(np.round(gyroid, 2), -3.0)


def ambiguous():
    data, spacing, _ = BUILTINS["ambiguous"].make(25, None)
    return data


CLOSED = {  # name: (volume, level, gradient direction); every surface closes inside the grid
    "sphere": (sphere, 0.0, "ascent"),
    "smooth noise": (smooth_noise, 0.0, "descent"),
    "plane with exact zeros": (integer_plane, 0.0, "descent"),
    "zero slab": (zero_slab, 0.0, "descent"),
    "rounded gyroid": (rounded_gyroid, 0.0, "descent"),
    "ambiguous": (ambiguous, 0.0, "descent"),
}


@pytest.mark.parametrize("name", list(CLOSED))
@pytest.mark.gl
def test_closed_manifold_outward_no_zero_area_and_gpu_equals_numpy(name):
    make, level, direction = CLOSED[name]
    volume = make()
    descent = direction == "descent"
    gpu = isoscope.marching_tetrahedra(volume, level, gradient_direction=direction, backend="gpu")
    cpu = isoscope.marching_tetrahedra(volume, level, gradient_direction=direction, backend="numpy")
    assert_same_mesh(gpu, cpu)
    verts, faces, normals, _ = gpu
    assert_closed_manifold(faces)  # every edge in two triangles, in opposite directions
    assert_clean_geometry(verts, faces)  # no zero-area triangle, no two vertices at one place
    assert len(verts) == tetrahedral_grid_crossings(volume, level, descent)
    assert len(np.unique(faces)) == len(verts)  # every vertex used: one per crossed edge, shared
    assert signed_volume(verts, faces) > 0  # counter-clockwise seen from outside encloses positive volume
    tri = verts[faces]
    face_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    agree = np.einsum("ij,ij->i", face_normals, normals[faces].sum(1)) > 0
    # Gradient normals and windings agree but where the padding's step or slivers bend the gradient.
    assert agree.mean() > (0.999 if name == "sphere" else 0.9)


def test_sphere_area_volume_and_topology():
    n, radius = 64, 0.6
    voxel = 2.0 / (n - 1)
    verts, faces, normals, values = isoscope.marching_tetrahedra(
        sphere(n, radius), 0.0, spacing=(voxel,) * 3, gradient_direction="ascent")
    assert euler_characteristic(verts, faces) == 2
    assert triangle_areas(verts, faces).sum() == pytest.approx(4 * np.pi * radius ** 2, rel=0.01)
    assert signed_volume(verts, faces) == pytest.approx(4 / 3 * np.pi * radius ** 3, rel=0.01)
    radial = (verts - 1.0) / np.linalg.norm(verts - 1.0, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", normals, radial).min() > 0.99
    assert np.abs(values).max() < voxel  # values: the field at the vertex, the level but for the edge margin


def test_plane_vertices_lie_on_the_plane():
    volume = integer_plane()
    verts, faces, normals, _ = isoscope.marching_tetrahedra(volume, 0.0)
    inner = ((verts >= 1) & (verts <= 24)).all(axis=1)  # on edges between the plane's samples, not the padding's
    x, y, z = (verts[inner] - 13).T
    assert inner.sum() > 2000
    # On the plane, to within the edge margin (1/256 of an edge, along which the field changes by at most 3).
    assert np.abs(x + 2 * y - 3 * z + 1).max() <= 3.0 / 256 + 1e-4


def test_tetrahedra_have_no_ambiguity_so_cubes_and_tetrahedra_differ_only_in_resolution():
    """On a smooth sphere the two meshes enclose the same volume to well within a voxel's worth."""
    volume = sphere(48)
    cubes = isoscope.api.outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu")
    tetra = isoscope.marching_tetrahedra(volume, 0.0, gradient_direction="ascent", backend="numpy")
    assert len(tetra[1]) > 1.5 * len(cubes[1])
    assert signed_volume(tetra[0], tetra[1]) == pytest.approx(signed_volume(cubes[0], cubes[1]), rel=0.01)


@pytest.mark.parametrize("shape", [(2, 2, 2), (17, 5, 33), (3, 2, 65), (2, 31, 32), (6, 4, 97), (9, 9, 64)])
def test_any_grid_size_matches_the_reference(gl_ctx, shape):
    volume = RNG.normal(size=shape).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as cubes:
        with TetraExtractor(cubes) as tetra:
            tetra.extract(0.05)
            gpu = tetra.read_mesh()
    assert_same_mesh(gpu, marching_tetrahedra_reference(volume, 0.05))
    assert len(gpu[0]) == tetrahedral_grid_crossings(volume, 0.05)


@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("dtype", [np.float32, np.int16, np.uint8])
def test_ties_spacing_and_integer_volumes_match_the_reference(gl_ctx, direction, dtype):
    volume = RNG.integers(0, 5, size=(19, 23, 40)).astype(dtype)  # about a fifth of samples tie
    spacing = (0.5, 2.0, 1.25)
    with Extractor(volume, spacing=spacing, gradient_direction=direction, ctx=gl_ctx) as cubes:
        with TetraExtractor(cubes) as tetra:
            tetra.extract(2.0)
            gpu = tetra.read_mesh()
    assert_same_mesh(gpu, marching_tetrahedra_reference(volume.astype(np.float32), 2.0, spacing,
                                                        direction == "descent"))


def test_shares_the_resident_volume_and_leaves_the_cubes_alone(gl_ctx):
    volume = RNG.normal(size=(30, 40, 50)).astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as cubes:
        with TetraExtractor(cubes) as tetra:
            assert tetra.resident is cubes.resident  # its volume image and brick ranges
            cubes.extract(0.3)
            tetra.extract(-0.2)  # between the cubes' extraction and its read-back
            assert_same_mesh(cubes.read_mesh(), marching_cubes_reference(volume, 0.3))
            for level in (2.5, 0.1):  # a level that cuts few bricks (skipping), then many
                tetra.extract(level)
                assert tetra.active_bricks <= tetra.brick_count
                assert_same_mesh(tetra.read_mesh(), marching_tetrahedra_reference(volume, level))
        cubes.extract(0.3)  # the cubes extractor outlives the tetrahedra's
        assert_same_mesh(cubes.read_mesh(), marching_cubes_reference(volume, 0.3))


def test_a_mesh_larger_than_one_storage_block_is_written_a_window_at_a_time(gl_ctx):
    volume = RNG.normal(size=(24, 25, 33)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 64 << 10)  # a brick's jobs fit one block
    with Extractor(volume, ctx=gl_ctx, limits=small) as cubes:
        with TetraExtractor(cubes) as tetra:
            n_vertices, n_triangles = tetra.extract(0.1)
            assert len(tetra.plan.windows(n_vertices, VERTEX_BYTES)) > 10
            assert len(tetra.plan.triangle_runs(n_triangles)) > 10
            assert_same_mesh(tetra.read_mesh(), marching_tetrahedra_reference(volume, 0.1))



def test_a_brick_with_more_vertex_jobs_than_a_storage_block_is_refused_and_the_extractor_still_works(gl_ctx):
    """Vertex jobs go to a buffer bound a window at a time (vertex_jobs.glsl), a brick's at least at once:
    with 4 KiB blocks (GL guarantees 128 MiB) a brick of noise has more than 512 tetrahedra jobs."""
    volume = RNG.normal(size=(12, 12, 20)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 4 << 10)
    few = float(np.sort(volume, axis=None)[-4])  # four samples inside: at most 4 * 14 vertices
    with Extractor(volume, ctx=gl_ctx, limits=small) as cubes:
        with TetraExtractor(cubes) as tetra:
            n_vertices, _ = tetra.extract(few)
            assert 0 < n_vertices <= 4 * 14
            with pytest.raises(GPULimitError, match="storage block") as refusal:
                tetra.extract(0.0)
            assert "\n" not in str(refusal.value)
            assert tetrahedral_grid_crossings(volume, 0.0) > 512
            expected = marching_tetrahedra_reference(volume, few)
            assert_same_mesh(tetra.read_mesh(), expected)  # the refusal left the last mesh as it was
            tetra.extract(few)
            assert_same_mesh(tetra.read_mesh(), expected)


def test_level_none_and_numpy_alias():
    volume = sphere(20)
    mid = (float(volume.min()) + float(volume.max())) / 2
    a = isoscope.marching_tetrahedra(volume, backend="cpu")
    b = isoscope.marching_tetrahedra(volume, mid, backend="numpy")
    np.testing.assert_array_equal(a[1], b[1])


BAD = [
    (np.zeros((4, 4)), 0.0, {}, "3-D"),
    (np.zeros((4, 1, 4)), 0.0, {}, "shorter than 2"),
    (np.arange(27.0).reshape(3, 3, 3), 99.0, {}, "outside the data range"),
    (np.where(np.arange(27) == 4, np.nan, 1.0).reshape(3, 3, 3), 0.5, {}, "NaN/Inf"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"backend": "cuda"}, "backend"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"gradient_direction": "up"}, "gradient_direction"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"spacing": (1, 0, 1)}, "spacing"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"smooth": -1}, "smooth"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"smooth": 1.5}, "smooth"),
]


@pytest.mark.parametrize("volume, level, kwargs, words", BAD)
def test_bad_arguments_are_one_line_value_errors(volume, level, kwargs, words):
    with pytest.raises(ValueError) as info:
        isoscope.marching_tetrahedra(volume, level, **kwargs)
    message = str(info.value)
    assert "\n" not in message and words in message


@pytest.mark.gl
def test_cli_exports_and_renders_tetrahedra(tmp_path):
    from isoscope.volumes import open_volume
    out = tmp_path / "amb.ply"
    result = isoscope_here("export", "ambiguous", "--tetrahedra", "--out", out)
    assert result.returncode == 0, result.stderr
    volume = open_volume("ambiguous")
    verts, _, _, faces = read_ply(out)
    assert len(verts) == tetrahedral_grid_crossings(volume.data, 0.0) and len(faces) > 0
    assert_closed_manifold(faces)

    pictures = []
    for extra in ([], ["--tetrahedra"]):
        png = tmp_path / f"amb{len(extra)}.png"
        result = isoscope_here("render", "ambiguous", "--size", "200x150", "--out", png, *extra)
        assert result.returncode == 0, result.stderr
        from PIL import Image
        pictures.append(np.asarray(Image.open(png).convert("RGB")).astype(int))
    # The same scene, a different surface: many pixels change, the background corner does not.
    changed = np.abs(pictures[0] - pictures[1]).max(axis=2) > 30
    assert changed.mean() > 0.01 and not changed[:5, :5].any()


@pytest.mark.gl
def test_bench_modes_reports_tetrahedra_and_the_trilinear_topology_against_cubes():
    script = REPO / "benchmarks" / "bench_modes.py"
    result = subprocess.run([sys.executable, str(script), "--sizes", "16", "--repeats", "1", "--warmup", "0"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    rows = [line.split("|")[1:-1] for line in result.stdout.splitlines() if line.startswith("| 16^3")]
    assert [(r[1].strip(), r[2].strip()) for r in rows] == [
        (v, m) for v in ("sphere", "gyroid", "noise") for m in ("cubes", "tetrahedra", "trilinear")]
    triangles = [int(row[5].replace(",", "")) for row in rows]
    for cubes, tetra, trilinear in zip(triangles[::3], triangles[1::3], triangles[2::3]):
        assert tetra > cubes > 0 and trilinear > 0  # tetrahedra: more triangles than cubes on every volume
    assert triangles[2] == triangles[0]  # the sphere has no ambiguous cell: the topologies agree
