"""export --space world: meshes in the scan's own coordinates (NIfTI RAS, NRRD and DICOM LPS)."""
from __future__ import annotations

import nibabel
import nrrd
import numpy as np
import pytest
from support.command import isoscope_here
from support.dicom_series import COL_DIR, NORMAL, ROW_DIR, ct_ball, write_series
from support.mesh_checks import read_ply, signed_volume

CENTRE = np.array([12.0, -30.0, 55.0])
RADIUS = 9.0


def oblique_mirrored_affine():
    """Rotated about two axes, anisotropic (0.9, 1.3, 2.0 mm), mirrored along the first axis, shifted."""
    a, b = 0.5, 0.3
    rotate = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]) @ \
        np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    affine = np.eye(4)
    affine[:3, :3] = rotate @ np.diag([-0.9, 1.3, 2.0])
    affine[:3, 3] = CENTRE - affine[:3, :3] @ np.array([15.0, 11.0, 7.0])   # the centre at index (15, 11, 7)
    return affine


def sphere_in(shape, index_to_world, centre_world):
    """Signed distance (negative inside) to a sphere given in world coordinates, at every voxel."""
    index = np.stack(np.meshgrid(*(np.arange(n) for n in shape), indexing="ij"), axis=-1).astype(np.float64)
    world = index @ index_to_world[:3, :3].T + index_to_world[:3, 3]
    return (np.linalg.norm(world - centre_world, axis=-1) - RADIUS).astype(np.float32)


def export(path, out, *flags):
    done = isoscope_here("export", path, "--iso", "0", "--inside", "below", "--out", out, *flags)
    assert done.returncode == 0, done.stderr
    return done.stdout, read_ply(out)


def assert_sphere_at(verts, normals, faces, centre, voxel):
    offsets = verts - centre
    distance = np.linalg.norm(offsets, axis=1)
    np.testing.assert_allclose(verts.mean(axis=0), centre, atol=voxel / 2)
    assert abs(distance.mean() - RADIUS) < voxel / 2
    assert (np.einsum("ij,ij->i", normals, offsets) > 0).mean() > 0.99      # normals point out
    assert signed_volume(verts, faces) > 0                                   # and so does the winding


def test_a_nifti_sphere_exports_to_its_ras_place_through_an_oblique_mirrored_affine(tmp_path):
    affine = oblique_mirrored_affine()
    assert np.linalg.det(affine[:3, :3]) < 0
    image = nibabel.Nifti1Image(sphere_in((30, 22, 14), affine, CENTRE), affine)
    image.set_sform(affine, code=1)
    nibabel.save(image, tmp_path / "ball.nii.gz")
    stdout, (verts, normals, _, faces) = export(tmp_path / "ball.nii.gz", tmp_path / "world.ply")
    assert "RAS coordinates" in stdout
    assert_sphere_at(verts, normals, faces, CENTRE, voxel=2.0)
    # --space voxel: index x spacing, the centre where its index (15, 11, 7) puts it.
    stdout, (verts, normals, _, faces) = export(tmp_path / "ball.nii.gz", tmp_path / "voxel.ply", "--space", "voxel")
    assert "index x spacing" in stdout
    np.testing.assert_allclose(verts.mean(axis=0), [15 * 0.9, 11 * 1.3, 7 * 2.0], atol=1.0)


def test_a_ras_nrrd_exports_in_lps(tmp_path):
    directions = np.diag([1.1, 0.8, 1.5])
    origin = np.array([-20.0, 10.0, 40.0])
    index_to_ras = np.eye(4)
    index_to_ras[:3, :3], index_to_ras[:3, 3] = directions.T, origin
    centre_ras = origin + directions.T @ np.array([12.0, 16.0, 9.0])
    nrrd.write(str(tmp_path / "ball.nrrd"), sphere_in((24, 32, 18), index_to_ras, centre_ras),
               {"space": "right-anterior-superior", "space directions": directions, "space origin": origin})
    stdout, (verts, normals, _, faces) = export(tmp_path / "ball.nrrd", tmp_path / "lps.ply")
    assert "LPS coordinates" in stdout
    assert_sphere_at(verts, normals, faces, centre_ras * [-1, -1, 1], voxel=1.5)


def test_a_dicom_ball_exports_to_its_patient_position(tmp_path):
    write_series(tmp_path / "ct", ct_ball(slices=16, rows=32, cols=36), step=-2.5)
    done = isoscope_here("export", tmp_path / "ct", "--iso", "-250", "--out", tmp_path / "ct.ply")
    assert done.returncode == 0 and "LPS coordinates" in done.stdout, done.stderr
    verts, normals, _, faces = read_ply(tmp_path / "ct.ply")
    # ct_ball's centre is at (slice 5.5, row 9.5, column 11.5) of the slices as written, the
    # first written at the origin and each next one 2.5 mm against the normal.
    centre = np.array([-40.0, 12.0, 100.0]) - 5.5 * 2.5 * NORMAL + 9.5 * 0.8 * COL_DIR + 11.5 * 0.6 * ROW_DIR
    np.testing.assert_allclose(verts.mean(axis=0), centre, atol=1.25)
    offsets = verts - centre
    assert (np.einsum("ij,ij->i", normals, offsets) > 0).mean() > 0.99 and signed_volume(verts, faces) > 0


@pytest.mark.parametrize("flag", [["--space", "galactic"]])
def test_an_unknown_space_is_a_usage_error(tmp_path, flag):
    done = isoscope_here("export", "torus", "--out", tmp_path / "t.ply", *flag)
    assert done.returncode == 2 and "--space" in done.stderr
