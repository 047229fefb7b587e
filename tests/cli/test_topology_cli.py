"""--topology on export and measure: the trilinear mesh written and read back by trimesh, its counts in
measure's JSON equal to an oracle of the interpolant, and the combinations it does not take in one line."""
from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from support.command import assert_one_line_error, isoscope_here
from support.topology import oracle
from support.trilinear_cases import closed_noise

import isoscope


def test_export_writes_the_trilinear_mesh(tmp_path):
    field = closed_noise(4, 9)
    np.save(tmp_path / "noise.npy", field)
    done = isoscope_here("export", tmp_path / "noise.npy", "--iso", "0", "--topology", "trilinear",
                         "--out", tmp_path / "noise.ply")
    assert done.returncode == 0, done.stderr
    mesh = trimesh.load(tmp_path / "noise.ply", process=False)
    verts, faces, _, _ = isoscope.api.outward_marching_cubes(field, 0.0, backend="numpy", topology="trilinear")
    np.testing.assert_allclose(mesh.vertices, verts, atol=1e-6)
    np.testing.assert_array_equal(mesh.faces, faces)
    assert mesh.is_watertight and mesh.is_winding_consistent


def test_measure_counts_what_the_interpolant_has(tmp_path):
    """The oracle (the interpolant refined, meshed by scikit-image) and measure --topology trilinear agree on
    pieces and Euler characteristic; today's default does not, on this field."""
    field = closed_noise(4, 9)
    truth = oracle(field, refinements=(8, 16))
    assert truth is not None
    np.save(tmp_path / "noise.npy", field)
    rows = {}
    for topology in ("montani", "trilinear"):
        done = isoscope_here("measure", tmp_path / "noise.npy", "--iso", "0", "--json", "--topology", topology)
        assert done.returncode == 0, done.stderr
        (rows[topology],) = json.loads(done.stdout)
    trilinear = rows["trilinear"]
    assert (trilinear["components"], trilinear["euler"]) == truth
    assert trilinear["genus"] == (2 * truth[0] - truth[1]) // 2   # closed: handles from the two counts
    assert (rows["montani"]["components"], rows["montani"]["euler"]) != truth


@pytest.mark.parametrize("args, words", [
    (["--topology", "trilinear", "--tetrahedra"], "not with tetrahedra"),
    (["--topology", "trilinear", "--sharp", "30"], "not with tetrahedra, sharp features"),
    (["--topology", "mc33"], "invalid choice"),
])
def test_export_refuses_what_the_topology_does_not_take(tmp_path, args, words):
    np.save(tmp_path / "noise.npy", closed_noise(4, 9))
    assert_one_line_error(isoscope_here("export", tmp_path / "noise.npy", "--iso", "0", *args,
                                        "--out", tmp_path / "x.ply"), words)


def test_measure_refuses_topology_with_labels(tmp_path):
    np.save(tmp_path / "seg.npy", np.pad(np.ones((4, 4, 4), np.uint8), 2))
    assert_one_line_error(isoscope_here("measure", tmp_path / "seg.npy", "--labels", "--topology", "trilinear"),
                          "--topology does not apply with --labels")


@pytest.mark.parametrize("command, flags", [
    ("export", ["--topology", "trilinear"]), ("export", ["--smooth", "2"]), ("export", ["--tetrahedra"]),
    ("export", ["--closed"]), ("render", ["--topology", "trilinear"]), ("render", ["--smooth", "3"]),
    ("render", ["--tetrahedra"]), ("render", ["--sharp", "30"]), ("movie", ["--smooth", "2"]),
    ("movie", ["--topology", "trilinear"]),
])
def test_a_label_maps_surfaces_refuse_the_mesh_modes(tmp_path, command, flags):
    """A label's surface is its boundary: a mesh mode given with --labels was dropped without a word (the PLY
    and the PNG were the same bytes with and without it)."""
    np.save(tmp_path / "seg.npy", np.pad(np.ones((4, 4, 4), np.uint8), 2))
    out = {"export": ["--out", tmp_path / "x.ply"], "render": ["--out", tmp_path / "x.png"],
           "movie": ["--out", tmp_path / "x.mp4"], "measure": []}[command]
    assert_one_line_error(isoscope_here(command, tmp_path / "seg.npy", "--labels", *flags, *out),
                          f"{flags[0]} does not apply with --labels")
    assert not any(tmp_path.glob("x*"))


@pytest.mark.parametrize("option", [dict(topology="trilinear"), dict(smooth=2), dict(tetrahedra=True),
                                    dict(level=0.5), dict(sharp_features=30)])
def test_isosurface_of_labels_refuses_what_it_would_drop(option):
    import isoscope
    from isoscope.errors import IsoscopeError
    labels = np.pad(np.ones((4, 4, 4), np.uint8), 2)
    with pytest.raises(IsoscopeError, match=f"{next(iter(option))} does not apply with labels=True"):
        isoscope.isosurface(labels, labels=True, **option)
    if next(iter(option)) in ("topology", "smooth", "tetrahedra"):   # render's modes: refused before any GL
        with pytest.raises(IsoscopeError, match=f"{next(iter(option))} does not apply with labels=True"):
            isoscope.render(labels, labels=True, **option)
    assert len(isoscope.isosurface(labels, labels=True, backend="cpu").faces) > 0
