"""label_surfaces: one closed surface per label, neighbours sharing their boundary vertices."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image
from support.mesh_checks import assert_closed_manifold, signed_volume

from isoscope import label_surfaces
from isoscope.cli.main import main
from isoscope.labels import label_colors


def ball(shape, centre, radius):
    g = np.indices(shape).astype(np.float64)
    return sum((g[a] - centre[a]) ** 2 for a in range(3)) <= radius ** 2


def three_labels():
    """Two balls pressed together (int16 labels 3 and -7) and a slab touching the border (5)."""
    labels = np.zeros((30, 31, 32), np.int16)
    labels[ball(labels.shape, (10, 15, 15), 6)] = 3
    labels[ball(labels.shape, (19, 15, 16), 6)] = -7
    labels[:4] = 5
    return labels


def assert_vertex_manifold(faces):
    """Around every vertex its triangles form one fan that closes (a disc, not two cones touching)."""
    for vertex in np.unique(faces):
        around = faces[(faces == vertex).any(axis=1)]
        # Each triangle's edge opposite the vertex, in winding order: they must chain into one cycle.
        opposite = [tuple(np.roll(t, -list(t).index(vertex))[1:]) for t in around]
        successor = dict(opposite)
        assert len(successor) == len(opposite), vertex
        start, steps = opposite[0][0], 1
        current = successor[start]
        while current != start:
            current, steps = successor[current], steps + 1
        assert steps == len(opposite), vertex


def touching_edges(labels, a, b):
    """Grid edges with label a at one end and b at the other: counted from the array alone."""
    count = 0
    for axis in range(3):
        lo, hi = np.moveaxis(labels, axis, 0)[:-1], np.moveaxis(labels, axis, 0)[1:]
        count += int(np.count_nonzero(((lo == a) & (hi == b)) | ((lo == b) & (hi == a))))
    return count


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_each_label_is_closed_manifold_and_wound_outward(backend):
    labels = three_labels()
    spacing = (1.0, 0.5, 2.0)
    surfaces = label_surfaces(labels, spacing=spacing, backend=backend)
    assert sorted(surfaces) == [-7, 3, 5]
    for label, (verts, faces, normals) in surfaces.items():
        assert verts.dtype == np.float32 and faces.dtype == np.int32 and normals.shape == verts.shape
        assert_closed_manifold(faces)
        assert_vertex_manifold(faces)
        assert len(np.unique(faces)) == len(verts)
        assert signed_volume(verts, faces) > 0, label  # counter-clockwise from outside
        # Normals point out: along the face normals around them, and away from the label's voxels.
        tri = verts[faces].astype(np.float64)
        face_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert (np.einsum("ij,ij->i", face_normals, normals[faces].mean(axis=1)) > 0).mean() > 0.99
        # Each vertex is the midpoint of a grid edge from a voxel of the label to one of another:
        # its normal's component along that edge points to the other voxel.
        doubled = np.rint(2 * verts / spacing).astype(int) + 2  # into the padded grid: borders close
        padded = np.pad(labels, 1)
        axis = np.argmax(doubled % 2, axis=1)
        rows = np.arange(len(verts))
        low = doubled // 2
        high = low.copy()
        high[rows, axis] += 1
        low_in, high_in = padded[tuple(low.T)] == label, padded[tuple(high.T)] == label
        assert (low_in != high_in).all()
        toward = np.where(low_in, 1.0, -1.0)
        assert (normals[rows, axis] * toward >= 0).all() and (normals[rows, axis] * toward > 0).mean() > 0.9


@pytest.mark.gl
def test_gpu_and_numpy_give_the_same_surfaces():
    labels = three_labels()
    gpu, cpu = label_surfaces(labels, backend="gpu"), label_surfaces(labels, backend="cpu")
    assert gpu.keys() == cpu.keys()
    for label in gpu:
        for g, c in zip(gpu[label], cpu[label]):
            np.testing.assert_allclose(g, c, atol=1e-5)


def test_neighbours_share_identical_boundary_vertices():
    labels = three_labels()
    surfaces = label_surfaces(labels, spacing=(0.7, 1.3, 0.9), backend="cpu")
    for a, b in [(3, -7), (3, 5)]:
        shared = set(map(tuple, surfaces[a][0])) & set(map(tuple, surfaces[b][0]))
        # One shared vertex per grid edge between the two labels, at exactly the same position.
        assert len(shared) == touching_edges(labels, a, b) > 0, (a, b)


@pytest.mark.parametrize("shape_name", ["ball 10", "ball 10 off the grid", "ball 11", "ball 14", "ball 20",
                                        "cube 10", "ellipsoid 10x14x18"])
def test_enclosed_volume_within_two_percent_of_the_voxel_count(shape_name):
    shape = (30, 30, 30)
    labels = np.zeros(shape, np.uint8)
    if shape_name == "ball 10 off the grid":
        labels[ball(shape, (14.3, 14.1, 14.7), 5)] = 2
    elif shape_name.startswith("ball"):
        across = int(shape_name.split()[1])
        labels[ball(shape, (14.5,) * 3 if across % 2 == 0 else (14,) * 3, across / 2)] = 2
    elif shape_name == "cube 10":
        labels[5:15, 8:18, 10:20] = 2
    else:
        g = np.indices(shape) - 14.5
        labels[(g[0] / 5) ** 2 + (g[1] / 7) ** 2 + (g[2] / 9) ** 2 <= 1] = 2
    labels[0, 0, 0] = 9  # a second label, in a corner: does not disturb label 2
    spacing = (0.5, 1.0, 1.5)
    verts, faces, _ = label_surfaces(labels, spacing=spacing, backend="cpu")[2]
    expected = np.count_nonzero(labels == 2) * np.prod(spacing)
    assert abs(signed_volume(verts, faces) / expected - 1) < 0.02


def test_wide_label_values_bool_input_and_no_labels():
    labels = np.zeros((6, 6, 6), np.uint32)
    labels[1:3, 1:3, 1:3] = 4_000_000_000
    labels[3:5, 3:5, 3:5] = 70_000
    assert sorted(label_surfaces(labels, backend="cpu")) == [70_000, 4_000_000_000]
    mask = np.zeros((4, 5, 6), bool)
    mask[1:3, 1:4, 1:5] = True
    assert list(label_surfaces(mask, backend="cpu")) == [1]
    assert label_surfaces(np.zeros((3, 3, 3), np.int8), backend="cpu") == {}


@pytest.mark.parametrize("labels, spacing, words", [
    (np.zeros((4, 4, 4), np.float32), (1, 1, 1), "integer array"),
    (np.zeros((4, 4), np.int32), (1, 1, 1), "3-D"),
    (np.zeros((4, 0, 4), np.int32), (1, 1, 1), "empty axis"),
    ("not an array", (1, 1, 1), "integer array"),
    (np.ones((4, 4, 4), np.int32), (1, -1, 1), "spacing"),
])
def test_bad_input_is_a_one_line_value_error(labels, spacing, words):
    with pytest.raises(ValueError, match=words) as info:
        label_surfaces(labels, spacing=spacing, backend="cpu")
    assert "\n" not in str(info.value)


def test_label_colours_are_distinct():
    for count in (1, 7, 20, 45):
        colors = label_colors(count)
        assert colors.shape == (count, 3)
        assert len(np.unique(np.round(colors, 3), axis=0)) == count


# -- the command line: isoscope render/export --labels -------------------------------------------

@pytest.fixture
def segmentation(tmp_path):
    """Two touching balls (labels 1 and 2) and a label-4 ball apart, saved as an .npy file."""
    labels = np.zeros((36, 36, 36), np.uint8)
    labels[ball(labels.shape, (11, 12, 12), 7)] = 1
    labels[ball(labels.shape, (24, 12, 12), 7)] = 2
    labels[ball(labels.shape, (18, 26, 24), 6)] = 4
    path = tmp_path / "seg.npy"
    np.save(path, labels)
    return path, labels


def test_export_writes_one_closed_mesh_per_label(tmp_path, segmentation, capsys):
    path, labels = segmentation
    assert main(["export", str(path), "--labels", "--out", str(tmp_path / "seg.stl")]) == 0
    assert "seg_label4.stl" in capsys.readouterr().out
    meshes = {n: trimesh.load(tmp_path / f"seg_label{n}.stl", process=True) for n in (1, 2, 4)}
    assert not (tmp_path / "seg.stl").exists() and not list(tmp_path.glob("*.partial"))
    for n, mesh in meshes.items():
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
        assert abs(mesh.volume / np.count_nonzero(labels == n) - 1) < 0.02
    shared = set(map(tuple, meshes[1].vertices)) & set(map(tuple, meshes[2].vertices))
    assert len(shared) == touching_edges(labels, 1, 2) > 0


@pytest.mark.parametrize("suffix", [".ply", ".glb"])
def test_export_one_file_colours_each_vertex_by_its_label(tmp_path, segmentation, suffix):
    path, labels = segmentation
    out = tmp_path / f"seg{suffix}"
    assert main(["export", str(path), "--labels", "--one-file", "--out", str(out)]) == 0
    mesh = trimesh.load(out, force="mesh", process=False)
    counts = {n: len(surface[0]) for n, surface in label_surfaces(labels).items()}
    assert len(mesh.vertices) == sum(counts.values())
    colors, per_color = np.unique(mesh.visual.vertex_colors[:, :3], axis=0, return_counts=True)
    assert sorted(per_color) == sorted(counts.values())
    expected = np.round(label_colors(3) * 255)
    assert {tuple(c) for c in colors} == {tuple(c) for c in expected.astype(np.uint8)}


@pytest.mark.gl
def test_render_draws_each_label_in_its_colour(tmp_path, segmentation):
    path, _ = segmentation
    out = tmp_path / "seg.png"
    assert main(["render", str(path), "--labels", "--out", str(out), "--size", "160x120"]) == 0
    pixels = np.asarray(Image.open(out).convert("RGB")).astype(int)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    # The labels in order (1, 2, 4) get tab20's blue, orange and green: each hue covers some pixels.
    assert np.count_nonzero(b > r + 60) > 100
    assert np.count_nonzero((r > b + 100) & (g > b + 40)) > 100   # orange
    assert np.count_nonzero((g > r + 50) & (g > b + 50)) > 100  # green


@pytest.mark.parametrize("argv, words", [
    (["export", "{seg}", "--labels", "--one-file", "--out", "{tmp}/seg.stl"], "--one-file needs a format"),
    (["export", "{seg}", "--one-file", "--out", "{tmp}/seg.ply"], "--one-file needs --labels"),
    (["export", "{seg}", "--labels", "--iso", "1", "--out", "{tmp}/seg.ply"], "--iso does not apply"),
    (["export", "{seg}", "--labels", "--decimate", "0.5", "--out", "{tmp}/seg.ply"], "--decimate does not apply"),
    (["render", "{seg}", "--labels", "--panel", "--out", "{tmp}/seg.png"], "--panel does not apply"),
    (["export", "sphere", "--resolution", "16", "--labels", "--out", "{tmp}/s.ply"], "not a label map"),
])
@pytest.mark.gl
def test_label_options_that_do_not_fit_are_one_line_errors(tmp_path, segmentation, capsys, argv, words):
    argv = [a.format(seg=segmentation[0], tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1
    assert not list(tmp_path.glob("seg*.ply")) and not list(tmp_path.glob("*.png"))


def test_label_files_name_their_space_and_a_nifti_map_lands_in_world_space(tmp_path, capsys):
    import nibabel
    labels = np.zeros((20, 20, 20), np.int16)
    labels[ball(labels.shape, (9.5, 9.5, 9.5), 6)] = 3
    affine = np.diag([2.0, 2.0, 2.0, 1.0])
    affine[:3, 3] = (-10, 20, 30)
    nibabel.save(nibabel.Nifti1Image(labels, affine), tmp_path / "seg.nii.gz")
    for suffix in (".ply", ".obj"):
        out = tmp_path / f"mesh{suffix}"
        assert main(["export", str(tmp_path / "seg.nii.gz"), "--labels", "--out", str(out)]) == 0
        written = tmp_path / f"mesh_label3{suffix}"
        assert b"isoscope mesh; vertex coordinates: RAS millimetres (world)" in written.read_bytes()[:200]
        mesh = trimesh.load(written, process=True)
        assert mesh.is_watertight and mesh.volume > 0
        assert abs(mesh.volume / (np.count_nonzero(labels == 3) * 8) - 1) < 0.02
        np.testing.assert_allclose(mesh.vertices.mean(axis=0), (9, 39, 49), atol=0.5)
    assert main(["export", str(tmp_path / "seg.nii.gz"), "--labels", "--space", "voxel",
                 "--out", str(tmp_path / "v.ply")]) == 0
    assert b"vertex coordinates: index x spacing\n" in (tmp_path / "v_label3.ply").read_bytes()[:200]
    # The isosurface export names its space too.
    assert main(["export", str(tmp_path / "seg.nii.gz"), "--iso", "1", "--out", str(tmp_path / "iso.obj")]) == 0
    assert (tmp_path / "iso.obj").read_text().startswith("# isoscope mesh; vertex coordinates: RAS millimetres")
