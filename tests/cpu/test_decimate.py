"""export --decimate: fewer triangles, the same closed surface, and an honest distance off the level set."""
from __future__ import annotations

import numpy as np
import pytest
from support.command import isoscope_here
from support.mesh_checks import assert_closed_manifold, read_ply, signed_volume

from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.decimate import decimate, distance_off_level_set, open_edges

SPACING = (0.5, 0.5, 1.0)


@pytest.fixture(scope="module")
def sphere():
    """A sphere of radius 10 (world units) in a 48x48x24 grid of anisotropic voxels, and its mesh."""
    i, j, k = np.meshgrid(*(np.arange(n) * s for n, s in zip((48, 48, 24), SPACING)), indexing="ij")
    field = (np.sqrt((i - 11.75) ** 2 + (j - 11.75) ** 2 + (k - 11.5) ** 2) - 10.0).astype(np.float32)
    verts, faces, normals, _ = marching_cubes_reference(field, 0.0, SPACING, descent=False)
    return field, verts, faces


def test_a_closed_surface_keeps_its_shape_and_stays_closed(sphere):
    field, verts, faces = sphere
    out_verts, out_faces, out_normals = decimate(verts, faces, 0.25)
    assert len(out_faces) == pytest.approx(0.25 * len(faces), rel=0.05)
    assert_closed_manifold(out_faces)
    assert open_edges(out_faces) == 0
    assert signed_volume(out_verts, out_faces) == pytest.approx(signed_volume(verts, faces), rel=0.02)
    radial = out_verts - out_verts.mean(axis=0)
    assert (np.einsum("ij,ij->i", out_normals, radial) > 0).mean() > 0.99     # outwards
    off = distance_off_level_set(field, SPACING, 0.0, out_verts)
    assert off.max() < 0.5 * max(SPACING) and off.mean() < 0.1 * max(SPACING)


def test_an_open_surface_keeps_its_border(sphere):
    field, verts, faces = sphere
    cut = verts[:, 2] < 11.5                                     # the lower half: an open bowl
    keep = cut[faces].all(axis=1)
    used = np.unique(faces[keep])
    index = np.full(len(verts), -1)
    index[used] = np.arange(len(used))
    bowl_verts, bowl_faces = verts[used], index[faces[keep]]
    border_before = open_edges(bowl_faces)
    out_verts, out_faces, _ = decimate(bowl_verts, bowl_faces, 0.3)
    assert len(out_faces) < 0.4 * len(bowl_faces) and open_edges(out_faces) == border_before


def test_the_distance_measures_how_far_points_are_off_the_level_set(sphere):
    field, verts, _ = sphere
    assert distance_off_level_set(field, SPACING, 0.0, verts).max() < 0.02      # vertices lie on it
    centre = np.array([11.75, 11.75, 11.5])
    shrunk = centre + 0.9 * (verts - centre)                                      # 1 unit inside it
    np.testing.assert_allclose(distance_off_level_set(field, SPACING, 0.0, shrunk), 1.0, atol=0.05)


def test_fractions_outside_zero_to_one_are_refused():
    for fraction in (0.0, -0.5, 1.5):
        with pytest.raises(ValueError, match="fraction of the triangles"):
            decimate(np.zeros((3, 3)), np.array([[0, 1, 2]]), fraction)


def test_the_command_line_decimates_and_reports(tmp_path):
    def export(*flags):   # the command in this process: the mesh it writes and what it says
        return isoscope_here("export", "torus", "--resolution", "32", "--out", tmp_path / "t.ply", *flags)
    full = export()
    assert full.returncode == 0, full.stderr
    full_faces = len(read_ply(tmp_path / "t.ply")[3])
    done = export("--decimate", "0.3")
    assert done.returncode == 0, done.stderr
    _, _, _, faces = read_ply(tmp_path / "t.ply")
    assert len(faces) == pytest.approx(0.3 * full_faces, rel=0.05)
    assert open_edges(faces) == 0 and "distance off the level set: max" in done.stdout
    refused = export("--decimate", "0")
    assert refused.returncode == 2 and "--decimate 0" in refused.stderr
