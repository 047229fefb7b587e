"""Samples exactly equal to the level (Bridson's exact-zero case) never break the mesh."""
import numpy as np
import pytest
from support.mesh_checks import (
    assert_clean_geometry,
    assert_closed_manifold,
    assert_holes_only_on_the_border,
    sign_changing_edges,
)

from isoscope.api import marching_cubes

BACKENDS = ["cpu", "gpu"]


def integer_plane(n=24):
    """x + 2y - 3z + 1 on an integer grid: every sample with x + 2y + 1 = 3z is exactly 0."""
    x, y, z = np.mgrid[:n, :n, :n].astype(np.float32) - n // 2
    return x + 2 * y - 3 * z + 1


def check_open(verts, faces, shape):
    assert_holes_only_on_the_border(verts, faces, shape)
    assert_clean_geometry(verts, faces)


@pytest.mark.parametrize("backend", BACKENDS)
def test_integer_plane_with_exact_zeros(backend):
    volume = integer_plane()
    assert np.count_nonzero(volume == 0) > 100
    verts, faces, normals, _ = marching_cubes(volume, 0.0, backend=backend)
    check_open(verts, faces, volume.shape)
    assert len(verts) == sign_changing_edges(volume, 0.0)
    # The plane's normal, pointing to lower values (out of the "descent" object): -(1, 2, -3)/|..|
    expected = -np.array([1.0, 2.0, -3.0]) / np.sqrt(14.0)
    assert np.allclose(normals, expected, atol=1e-5)
    # Every vertex lies on the plane, to within the edge margin that keeps vertices off grid points.
    x, y, z = (verts - volume.shape[0] // 2).T
    assert np.abs(x + 2 * y - 3 * z + 1).max() <= 3.0 / 256 + 1e-4


@pytest.mark.parametrize("backend", BACKENDS)
def test_whole_grid_plane_at_the_level(backend):
    """A field whose plane k = 6 equals the level exactly, below it elsewhere: a thin closed slab."""
    k = np.arange(12, dtype=np.float32)
    volume = np.broadcast_to(-np.abs(k - 6), (10, 11, 12)).copy()
    volume = np.pad(volume, 1, constant_values=-10.0)
    verts, faces, _, _ = marching_cubes(volume, 0.0, backend=backend)
    assert_closed_manifold(faces)
    assert_clean_geometry(verts, faces)
    assert len(verts) == sign_changing_edges(volume, 0.0)
    # And the plain step: level equal to a whole plane of a ramp gives one flat sheet.
    ramp = np.broadcast_to(k - 6, (8, 9, 12)).astype(np.float32).copy()
    verts, faces, _, _ = marching_cubes(ramp, 0.0, backend=backend)
    check_open(verts, faces, ramp.shape)
    assert np.allclose(verts[:, 2], 6 - 1 / 256, atol=1e-5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_gyroid_rounded_to_two_decimals(backend):
    t = np.mgrid[:40, :40, :40].astype(np.float64) * (2 * np.pi / 20)
    gyroid = np.sin(t[0]) * np.cos(t[1]) + np.sin(t[1]) * np.cos(t[2]) + np.sin(t[2]) * np.cos(t[0])
    volume = np.pad(np.round(gyroid, 2), 1, constant_values=-3.0).astype(np.float32)
    assert np.count_nonzero(volume == 0) > 50
    verts, faces, _, _ = marching_cubes(volume, 0.0, backend=backend)
    assert_closed_manifold(faces)
    assert_clean_geometry(verts, faces)
    assert len(verts) == sign_changing_edges(volume, 0.0)


def saddle_ties(volume: np.ndarray) -> int:
    """Faces of cells normal to axis 0 whose corners alternate about 0 and whose bilinear saddle is exactly 0
    (a * c == b * d): there the interpolant's level set crosses itself, and the tie rule decides."""
    a, b, c, d = volume[:, :-1, :-1], volume[:, 1:, :-1], volume[:, 1:, 1:], volume[:, :-1, 1:]
    alternate = ((a >= 0) == (c >= 0)) & ((b >= 0) == (d >= 0)) & ((a >= 0) != (b >= 0))
    return int(np.count_nonzero(alternate & (a * c == b * d)))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("seed", [0, 1])
def test_ties_with_the_trilinear_topology(seed, backend):
    """Small integers: samples exactly at the level and faces whose saddle is exactly the level, everywhere.
    The trilinear topology's mesh is closed, 2-manifold, with no zero-area triangle and today's vertex on every
    sign-changing edge; each backend gives the numpy specification's mesh bit for bit (normals within an ulp)."""
    from isoscope.cpu.trilinear import trilinear_parts
    volume = np.random.default_rng(seed).integers(-3, 4, (14, 14, 14)).astype(np.float32)
    volume = np.pad(volume, 1, constant_values=-5.0)
    assert np.count_nonzero(volume == 0) > 300 and saddle_ties(volume) > 20
    meshes = [marching_cubes(volume, 0.0, backend=b, topology="trilinear") for b in ("numpy", backend)]
    verts, faces, _, _ = meshes[0]
    assert_closed_manifold(faces)
    assert_clean_geometry(verts, faces)
    assert len(trilinear_parts(volume, 0.0)[0]) == sign_changing_edges(volume, 0.0)
    for other in meshes[1:]:
        for part in (0, 1, 3):   # positions, faces, values; normals within an ulp, as for today's mesh
            np.testing.assert_array_equal(meshes[0][part], other[part])
        np.testing.assert_allclose(meshes[0][2], other[2], atol=1e-6)
