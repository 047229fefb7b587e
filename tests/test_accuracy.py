"""Areas and volumes against analytic values."""
import numpy as np
import pytest
from skimage.draw import ellipsoid, ellipsoid_stats
from support.mesh_checks import assert_closed_manifold, euler_characteristic, signed_volume, triangle_areas

import isoscope
from isoscope.api import outward_marching_cubes


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_sphere_area_volume_and_outward_normals(sphere_sdf, backend):
    volume, radius, voxel = sphere_sdf
    verts, faces, normals, _ = outward_marching_cubes(volume, 0.0, spacing=(voxel,) * 3,
                                                      gradient_direction="ascent", backend=backend)
    assert_closed_manifold(faces)
    assert euler_characteristic(verts, faces) == 2
    area = triangle_areas(verts, faces).sum()
    enclosed = signed_volume(verts, faces)  # positive: counter-clockwise seen from outside
    assert area == pytest.approx(4 * np.pi * radius**2, rel=0.01)
    assert enclosed == pytest.approx(4 / 3 * np.pi * radius**3, rel=0.01)

    centre = np.full(3, 1.0)  # the grid spans [-1, 1], vertices start at 0
    radial = (verts - centre) / np.linalg.norm(verts - centre, axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    assert np.einsum("ij,ij->i", normals, radial).min() > 0.99
    tri = verts[faces]
    face_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert (np.einsum("ij,ij->i", face_normals, normals[faces].sum(1)) > 0).all()


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_scikit_image_ellipsoid_area(backend):
    _, surface = ellipsoid_stats(6, 10, 16)
    levelset = ellipsoid(6, 10, 16, levelset=True)
    verts, faces, _, _ = isoscope.marching_cubes(levelset, 0.0, backend=backend)
    assert triangle_areas(verts, faces).sum() == pytest.approx(surface, rel=0.01)

    spacing = (1.0, 10 / 6.0, 16 / 6.0)
    levelset = ellipsoid(6, 10, 16, spacing=spacing, levelset=True)
    verts, faces, _, _ = isoscope.marching_cubes(levelset, 0.0, spacing=spacing, backend=backend)
    assert triangle_areas(verts, faces).sum() == pytest.approx(surface, rel=0.015)
