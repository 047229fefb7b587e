"""`isoscope measure` (issue 26): area, enclosed volume, pieces and box per surface, against the analytic
sphere, against trimesh on the exported file, and its refusals in one line."""
from __future__ import annotations

import json
import math

import nibabel
import numpy as np
import pytest
import trimesh
from support.command import assert_one_line_error, isoscope_here

from isoscope.cpu.measure import components, measure_surface

R = 0.6


def ball_field(n=81, centres=((0.0, 0.0, 0.0),), radius=R):
    axis = np.linspace(-1, 1, n, dtype=np.float64)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    distance = np.min([np.sqrt((x - a) ** 2 + (y - b) ** 2 + (z - c) ** 2) for a, b, c in centres], axis=0)
    return (radius - distance).astype(np.float32)


def measured(*args):
    result = isoscope_here("measure", *args, "--json")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)   # stdout holds the JSON and nothing else


def test_a_sphere_measures_as_the_analytic_one(tmp_path):
    np.save(tmp_path / "ball.npy", ball_field())
    spacing = 2.0 / 80   # the grid spans -1..1 in 80 cells: world units are the field's
    (record,) = measured(tmp_path / "ball.npy", "--iso", "0", "--spacing", *[str(spacing)] * 3)
    assert record["level"] == 0.0 and record["components"] == 1 and record["open_edges"] == 0
    assert record["area_mm2"] == pytest.approx(4 * math.pi * R * R, rel=0.01)
    assert record["volume_ml"] * 1000 == pytest.approx(4 / 3 * math.pi * R ** 3, rel=0.01)
    assert record["largest_component_ml"] == record["volume_ml"]
    lo, hi = np.array(record["bbox_min"]), np.array(record["bbox_max"])
    assert np.allclose(hi - lo, 2 * R, atol=spacing) and np.allclose((hi + lo) / 2, 1.0, atol=spacing)


def test_measures_agree_with_trimesh_on_the_exported_file_in_world_millimetres(tmp_path):
    affine = np.diag([2.0, -1.5, 1.0, 1.0])   # 2 x 1.5 x 1 mm voxels, y mirrored: RAS world coordinates
    affine[:3, 3] = (10, 20, -5)
    nibabel.save(nibabel.Nifti1Image(ball_field(61, ((0.3, 0, 0), (-0.5, 0.1, 0)), 0.3), affine), tmp_path / "b.nii")
    records = measured(tmp_path / "b.nii", "--iso", "0")
    assert isoscope_here("export", tmp_path / "b.nii", "--iso", "0", "--out", tmp_path / "b.stl").returncode == 0
    mesh = trimesh.load(tmp_path / "b.stl", force="mesh")
    (record,) = records
    assert record["components"] == 2 == len(mesh.split(only_watertight=False))
    assert record["area_mm2"] == pytest.approx(mesh.area, rel=0.005)
    assert record["volume_ml"] * 1000 == pytest.approx(mesh.volume, rel=0.005)
    assert np.allclose(record["bbox_min"], mesh.bounds[0], atol=1e-3)
    assert np.allclose(record["bbox_max"], mesh.bounds[1], atol=1e-3)
    assert record["largest_component_ml"] < record["volume_ml"]


def test_labels_are_measured_one_by_one(tmp_path):
    labels = np.zeros((20, 20, 20), np.uint8)
    labels[2:8, 2:8, 2:8] = 1        # a 6^3 cube of voxels
    labels[10:18, 3:7, 3:7] = 3
    np.save(tmp_path / "seg.npy", labels)
    records = measured(tmp_path / "seg.npy", "--labels")
    assert [r["label"] for r in records] == [1, 3]
    assert all(r["components"] == 1 and r["open_edges"] == 0 for r in records)
    # the label surface runs through the voxels' boundary midpoints: volume near the voxel count
    assert records[0]["volume_ml"] * 1000 == pytest.approx(6 ** 3, rel=0.15)
    assert records[1]["volume_ml"] > records[0]["volume_ml"] * 0.5


def test_text_output_names_an_open_surface(tmp_path):
    np.save(tmp_path / "cut.npy", ball_field()[:, :, :40])   # the ball cut in half by the volume's edge
    result = isoscope_here("measure", tmp_path / "cut.npy", "--iso", "0")
    assert result.returncode == 0 and "open at" in result.stdout and "mm^2" in result.stdout


@pytest.mark.parametrize("args, words", [
    (("--iso", "5"), ("--iso 5 is outside",)),
    (("--labels", "--iso", "0"), ("--iso", "--labels")),
    (("--max-labels", "3"), ("--max-labels needs --labels",)),
])
def test_bad_measures_are_one_line(tmp_path, args, words):
    np.save(tmp_path / "ball.npy", ball_field(21))
    assert_one_line_error(isoscope_here("measure", tmp_path / "ball.npy", *args), *words)


def test_pieces_by_shared_vertices():
    faces = np.array([[0, 1, 2], [2, 3, 0], [4, 5, 6], [7, 8, 9], [9, 10, 7]])
    labels = components(12, faces)
    assert len(np.unique(labels[:11])) == 3 and labels[11] == 11   # vertex 11 is in no triangle
    long_strip = np.array([[i, i + 1, i + 2] for i in range(2000)])   # one piece across 2002 vertices
    assert len(np.unique(components(2002, long_strip))) == 1
    empty = measure_surface(np.zeros((0, 3)), np.zeros((0, 3), np.int32))
    assert empty.components == 0 and empty.area == 0.0


def test_closed_caps_a_surface_that_leaves_the_volume(tmp_path):
    """export/measure --closed: the half ball cut by the volume's edge gets a cap there: 0 open edges,
    watertight in trimesh, its volume counted; the open export is left open."""
    from support.mesh_checks import edge_use_counts
    np.save(tmp_path / "cut.npy", ball_field()[:, :, :40])
    for closed in ((), ("--closed",)):
        out = tmp_path / f"cut{len(closed)}.ply"
        assert isoscope_here("export", tmp_path / "cut.npy", "--iso", "0", *closed, "--out", out).returncode == 0
        mesh = trimesh.load(out, force="mesh", process=False)
        _, counts = edge_use_counts(np.asarray(mesh.faces))
        assert (set(counts.tolist()) == {2}) == bool(closed) and mesh.is_watertight == bool(closed)
    (record,) = measured(tmp_path / "cut.npy", "--iso", "0", "--closed", "--spacing", *["0.025"] * 3)
    assert record["open_edges"] == 0
    half = 4 / 3 * math.pi * R ** 3 / 2   # the last sample kept is at z = -0.025: a slab that thick less
    assert record["volume_ml"] * 1000 == pytest.approx(half - math.pi * R * R * 0.025, rel=0.01)
    assert_one_line_error(isoscope_here("export", tmp_path / "cut.npy", "--closed", "--chunk", "16", "--out",
                                        tmp_path / "c.stl"), "--closed", "chunked")


def test_a_reader_that_leaves_early_ends_it_quietly():
    """`isoscope measure --json | true`: the reader is gone before the JSON is written (the command takes
    a good part of a second to start): no 'Broken pipe' error, the status SIGPIPE's (141)."""
    import subprocess
    import sys
    done = subprocess.run(["bash", "-c", f'"{sys.executable}" -m isoscope measure torus --json | true; '
                                         'echo "${PIPESTATUS[0]}"'], capture_output=True, text=True, timeout=120)
    assert done.stderr == "" and done.stdout.split()[-1] == "141", (done.stdout, done.stderr)


def _ball_series(path, radii=(0.3, 0.5, 0.7)):
    x, y, z = np.mgrid[-1:1:40j, -1:1:40j, -1:1:40j]
    r = np.sqrt(x * x + y * y + z * z)
    np.save(path, np.stack([(r < a).astype(np.float32) for a in radii]))


def test_measure_takes_time_all_and_ranges_a_row_per_time_point(tmp_path):
    import json
    _ball_series(tmp_path / "grow.npy")
    done = isoscope_here("measure", tmp_path / "grow.npy", "--iso", "0.5", "--time", "all", "--json")
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)
    assert [row["time"] for row in rows] == [0, 1, 2]
    volumes = [row["volume_ml"] for row in rows]
    assert volumes == sorted(volumes) and volumes[0] < volumes[-1]
    for row in rows:   # each row is measure --time N of that time point
        alone = json.loads(isoscope_here("measure", tmp_path / "grow.npy", "--iso", "0.5", "--time", str(row["time"]),
                                         "--json").stdout)
        assert alone == [{k: v for k, v in row.items() if k != "time"}]
    part = isoscope_here("measure", tmp_path / "grow.npy", "--iso", "0.5", "--time", "1:3")
    assert part.returncode == 0 and [line.split(",")[0] for line in part.stdout.splitlines()] == ["time 1", "time 2"]


def test_measure_names_the_cavities_among_the_pieces(tmp_path):
    x, y, z = np.mgrid[-1:1:40j, -1:1:40j, -1:1:40j]
    r = np.sqrt(x * x + y * y + z * z)
    np.save(tmp_path / "shell.npy", ((r < 0.8) & (r > 0.5)).astype(np.float32))
    done = isoscope_here("measure", tmp_path / "shell.npy", "--iso", "0.5")
    assert done.returncode == 0, done.stderr
    assert "2 pieces" in done.stdout and "1 of them a cavity taking" in done.stdout
    import json
    row = json.loads(isoscope_here("measure", tmp_path / "shell.npy", "--iso", "0.5", "--json").stdout)[0]
    assert row["cavities"] == 1
    # the hollow ball's volume is the outer piece less the cavity, each a ball of its radius (in voxels)
    assert row["volume_ml"] == pytest.approx(row["largest_component_ml"] - row["cavities_ml"], rel=1e-9)
    assert row["cavities_ml"] * 1000 == pytest.approx(4 / 3 * np.pi * (0.5 * 19.5) ** 3, rel=0.03)


def torus_field(n=48, major=0.55, minor=0.22, holes=1):
    """Positive inside a solid torus (holes=1) or two fused tori side by side (holes=2: a genus-2 pretzel)."""
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    if holes == 2:   # two rings fused where they meet: x from -0.8 to 0.8
        major, minor = 0.3, 0.12
    parts = []
    for centre in ((0.0,) if holes == 1 else (-0.38, 0.38)):
        ring = np.sqrt((x - centre) ** 2 + y ** 2) - major
        parts.append(minor - np.sqrt(ring ** 2 + z ** 2))
    return np.max(parts, axis=0).astype(np.float32)


@pytest.mark.parametrize("holes", [1, 2])
def test_measure_counts_the_handles_of_a_closed_surface(tmp_path, holes):
    np.save(tmp_path / "torus.npy", torus_field(holes=holes))
    (row,) = measured(tmp_path / "torus.npy", "--iso", "0")
    assert row["components"] == 1 and row["open_edges"] == 0
    assert row["euler"] == 2 - 2 * holes and row["genus"] == holes
    text = isoscope_here("measure", tmp_path / "torus.npy", "--iso", "0").stdout
    assert f"Euler characteristic {2 - 2 * holes}, genus {holes}" in text


def test_topology_of_balls_a_shell_and_an_open_surface(tmp_path):
    two = measure_surface(*_mesh(ball_field(centres=((-0.5, 0, 0), (0.5, 0, 0)), radius=0.3)))
    assert (two.components, two.euler, two.genus) == (2, 4, 0)
    x, y, z = np.mgrid[-1:1:40j, -1:1:40j, -1:1:40j]
    r = np.sqrt(x * x + y * y + z * z)
    shell = measure_surface(*_mesh(((r < 0.8) & (r > 0.5)).astype(np.float32), 0.5))
    assert (shell.components, shell.cavities, shell.euler, shell.genus) == (2, 1, 4, 0)
    cut = measure_surface(*_mesh(ball_field(radius=1.3)))   # leaves the volume: a sphere with six holes
    assert cut.open_edges and cut.genus is None and cut.euler == 2 - 6


def _mesh(field, level=0.0):
    from isoscope.cpu.cubes import marching_cubes_reference
    verts, faces, _, _ = marching_cubes_reference(field, level)
    return verts, faces
