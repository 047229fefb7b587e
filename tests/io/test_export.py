"""Mesh files: each format written through trimesh and read back by a reader written here from its spec."""
from __future__ import annotations

import json
import os
import struct

import numpy as np
import pytest
from support.command import isoscope_here
from support.mesh_checks import assert_closed_manifold, read_ply, signed_volume

from isoscope.api import outward_marching_cubes
from isoscope.io.export import FORMATS, write_mesh


@pytest.fixture(scope="module")
def sphere_mesh():
    n = 24
    axis = np.linspace(-1, 1, n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    field = (np.sqrt(x * x + y * y + z * z) - 0.7).astype(np.float32)
    verts, faces, normals, _ = outward_marching_cubes(field, 0.0, spacing=(0.5, 1, 2), gradient_direction="ascent",
                                                      backend="cpu")
    return verts, faces, normals


def read_stl(path):
    """Binary STL: 80-byte header, uint32 count, then per triangle a normal, 3 corners and 2 bytes."""
    data = path.read_bytes()
    (count,) = struct.unpack_from("<I", data, 80)
    assert len(data) == 84 + 50 * count
    records = np.frombuffer(data, np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")]),
                            count, 84)
    return records["corners"], records["normal"]


def read_obj(path):
    verts, normals, faces = [], [], []
    for line in path.read_text().splitlines():
        kind, *rest = line.split() or [""]
        if kind == "v":
            verts.append([float(v) for v in rest[:3]])
        elif kind == "vn":
            normals.append([float(v) for v in rest])
        elif kind == "f":
            corners = [item.split("/") for item in rest]
            assert all(c[0] == c[-1] for c in corners), "each corner's normal is its vertex's"
            faces.append([int(c[0]) - 1 for c in corners])
    return np.array(verts), np.array(normals), np.array(faces)


def read_off(path):
    lines = [line for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")]
    assert lines[0].strip() == "OFF"
    n_verts, n_faces, _ = (int(v) for v in lines[1].split())
    verts = np.array([[float(v) for v in line.split()] for line in lines[2:2 + n_verts]])
    faces = np.array([[int(v) for v in line.split()] for line in lines[2 + n_verts:2 + n_verts + n_faces]])
    assert (faces[:, 0] == 3).all()
    return verts, faces[:, 1:]


def read_glb(path):
    """The binary glTF's JSON chunk and binary chunk, and its one primitive's arrays."""
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    json_length, _ = struct.unpack_from("<II", data, 12)
    document = json.loads(data[20:20 + json_length])
    binary = data[20 + json_length + 8:]
    (primitive,) = document["meshes"][0]["primitives"]

    def accessor(index, dtype, width):
        acc = document["accessors"][index]
        view = document["bufferViews"][acc["bufferView"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        return np.frombuffer(binary, dtype, acc["count"] * width, start).reshape(acc["count"], width)
    index_type = {5125: "<u4", 5123: "<u2"}[document["accessors"][primitive["indices"]]["componentType"]]
    faces = accessor(primitive["indices"], index_type, 1).reshape(-1, 3)
    return (accessor(primitive["attributes"]["POSITION"], "<f4", 3),
            accessor(primitive["attributes"]["NORMAL"], "<f4", 3), faces)


def test_ply_round_trips_exactly(tmp_path, sphere_mesh):
    verts, faces, normals = sphere_mesh
    read_verts, read_normals, counts, read_faces = read_ply(write_mesh(tmp_path / "sphere.ply", *sphere_mesh))
    np.testing.assert_array_equal(read_verts, verts)
    np.testing.assert_array_equal(read_normals, normals)   # ours, not recomputed
    np.testing.assert_array_equal(read_faces, faces)
    assert (counts == 3).all()


def test_obj_off_and_glb_keep_vertices_faces_and_normals(tmp_path, sphere_mesh):
    verts, faces, normals = sphere_mesh
    obj_verts, obj_normals, obj_faces = read_obj(write_mesh(tmp_path / "sphere.obj", *sphere_mesh))
    np.testing.assert_allclose(obj_verts, verts, atol=1e-6)
    np.testing.assert_allclose(obj_normals, normals, atol=1e-6)
    np.testing.assert_array_equal(obj_faces, faces)
    off_verts, off_faces = read_off(write_mesh(tmp_path / "sphere.off", *sphere_mesh))
    np.testing.assert_allclose(off_verts, verts, atol=1e-6)
    np.testing.assert_array_equal(off_faces, faces)
    glb_verts, glb_normals, glb_faces = read_glb(write_mesh(tmp_path / "sphere.glb", *sphere_mesh))
    np.testing.assert_array_equal(glb_verts, verts)
    np.testing.assert_allclose(glb_normals, normals, atol=1e-6)
    np.testing.assert_array_equal(glb_faces, faces)
    for read_faces, read_verts in ((obj_faces, obj_verts), (off_faces, off_verts), (glb_faces, glb_verts)):
        assert_closed_manifold(read_faces)
        assert signed_volume(read_verts, read_faces) > 0           # wound outwards


def test_stl_is_binary_with_outward_face_normals(tmp_path, sphere_mesh):
    verts, faces, _ = sphere_mesh
    corners, face_normals = read_stl(write_mesh(tmp_path / "sphere.stl", *sphere_mesh))
    np.testing.assert_array_equal(corners, verts[faces])
    outward = corners.mean(axis=1) - verts.mean(axis=0)
    assert (np.einsum("ij,ij->i", face_normals, outward) > 0).all()


def test_the_extension_picks_the_format_and_any_other_is_refused(tmp_path, sphere_mesh):
    assert set(FORMATS) == {".ply", ".obj", ".stl", ".glb", ".off"}
    for name in ("mesh.vtk", "mesh"):
        with pytest.raises(ValueError) as err:
            write_mesh(tmp_path / name, *sphere_mesh)
        assert ".ply, .obj, .stl, .glb, .off" in str(err.value) and "\n" not in str(err.value)
        assert not (tmp_path / name).exists()
    assert read_stl(write_mesh(tmp_path / "UPPER.STL", *sphere_mesh))[0].shape[0] == len(sphere_mesh[1])


def test_a_failed_write_leaves_the_existing_file_and_no_partial_file(tmp_path, sphere_mesh, monkeypatch):
    target = tmp_path / "kept.ply"
    target.write_bytes(b"the good file")
    with pytest.raises(ValueError, match="face indices"):          # bad input: refused before writing
        write_mesh(target, sphere_mesh[0], sphere_mesh[1] + 10**6, sphere_mesh[2])

    def disk_full(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", disk_full)                      # the data is written, then the disk fills
    with pytest.raises(OSError, match="No space"):
        write_mesh(target, *sphere_mesh)
    assert target.read_bytes() == b"the good file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.ply"]


def test_a_directory_in_the_way_is_not_clobbered(tmp_path, sphere_mesh):
    (tmp_path / "mesh.obj").mkdir()
    with pytest.raises(OSError):
        write_mesh(tmp_path / "mesh.obj", *sphere_mesh)
    assert (tmp_path / "mesh.obj").is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["mesh.obj"]


def test_an_empty_mesh_and_inconsistent_input_are_refused(tmp_path):
    empty = (np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros((0, 3)))
    with pytest.raises(ValueError, match="no surface at this level"):
        write_mesh(tmp_path / "empty.ply", *empty)
    assert not (tmp_path / "empty.ply").exists()
    with pytest.raises(ValueError, match="normals"):
        write_mesh(tmp_path / "bad.ply", np.zeros((3, 3)), [[0, 1, 2]], np.zeros((2, 3)))


def test_the_command_line_writes_stl_and_refuses_an_unknown_extension(tmp_path):
    def export(out):
        return isoscope_here("export", "torus", "--resolution", "24", "--out", out)
    done = export(tmp_path / "torus.stl")
    assert done.returncode == 0, done.stderr
    corners, _ = read_stl(tmp_path / "torus.stl")
    assert len(corners) > 100 and f"{len(corners):,} triangles" in done.stdout
    refused = export(tmp_path / "torus.xyz")
    assert refused.returncode == 2 and ".ply, .obj, .stl, .glb, .off" in refused.stderr
    assert refused.stderr.count("\n") == 1 and not (tmp_path / "torus.xyz").exists()
