"""The PLY writer, checked by reading the file back byte for byte."""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.export import write_ply

from mesh_checks import read_ply


def test_marching_cubes_mesh_round_trips(tmp_path, sphere_sdf):
    from isoscope import marching_cubes
    field, _, _ = sphere_sdf
    verts, faces, normals, _ = marching_cubes(field[::2, ::2, ::2], 0.0, spacing=(0.5, 1, 2),
                                              gradient_direction="ascent")
    path = write_ply(tmp_path / "sphere.ply", verts, faces, normals)
    read_verts, read_normals, counts, read_faces = read_ply(path)
    assert len(read_verts) == len(verts) > 100 and len(read_faces) == len(faces)
    np.testing.assert_array_equal(read_verts, verts)
    np.testing.assert_array_equal(read_normals, normals)
    np.testing.assert_array_equal(read_faces, faces)
    assert (counts == 3).all()


def test_empty_mesh_is_a_valid_file(tmp_path):
    path = write_ply(tmp_path / "empty.ply", np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros((0, 3)))
    verts, normals, counts, faces = read_ply(path)
    assert len(verts) == len(faces) == 0


def test_inconsistent_input_is_refused_with_one_line(tmp_path):
    verts = np.zeros((3, 3))
    with pytest.raises(ValueError, match="face indices"):
        write_ply(tmp_path / "bad.ply", verts, [[0, 1, 3]], verts)
    with pytest.raises(ValueError, match="normals"):
        write_ply(tmp_path / "bad.ply", verts, [[0, 1, 2]], verts[:2])
