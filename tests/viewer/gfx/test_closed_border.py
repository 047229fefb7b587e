"""Closed at the border in the viewer and `render --closed` (issue 26, point 11): a surface that leaves the
volume is capped there.  The caps weld to the surface with no open edge (counted as export's check
counts them), the picture shows the cap in the surface's front colour where the open surface showed its
inside, Save mesh writes a watertight file (trimesh reads it back), and a saved scene keeps the setting.
"""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from support.command import assert_one_line_error, isoscope_here

from isoscope.cpu.measure import measure_surface, open_edge_count
from isoscope.one_shot import border_caps, closed_mesh, extraction_of
from isoscope.viewer.gfx.saving import save_mesh
from isoscope.volumes.volume import finish_volume

N, RADIUS = 40, 12.0


def cut_ball(centre=(0.0, 20.0, 20.0), direction="descent", spacing=(1.0, 1.0, 1.0)):
    """A ball of RADIUS centred on the volume's x = 0 face (or `centre`): positive inside for descent."""
    points = np.indices((N, N, N)).astype(np.float32) - np.asarray(centre, np.float32)[:, None, None, None]
    inside = (RADIUS - np.sqrt((points ** 2).sum(axis=0))).astype(np.float32)
    return inside if direction == "descent" else -inside


def welded(verts, faces, decimals=4):
    """`faces` over vertices merged by position (the surface's and the caps' rims are the same points)."""
    key = np.round(np.asarray(verts, np.float64) * 10 ** decimals).astype(np.int64)
    _, merged = np.unique(key, axis=0, return_inverse=True)
    return merged.reshape(-1)[faces]


@pytest.mark.parametrize("cells", ["cubes", "tetrahedra"])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("centre", [(0.0, 20.0, 20.0), (39.0, 0.0, 39.0)], ids=["face", "corner"])
def test_caps_close_the_surface_where_it_leaves_the_volume(cells, direction, centre):
    data = cut_ball(centre, direction)
    spacing = (1.0, 0.8, 1.25)
    verts, faces, _, _ = extraction_of(cells)(data, 0.0, spacing=spacing, gradient_direction=direction, backend="cpu")
    assert open_edge_count(faces) > 0   # open where it leaves the volume
    cap_verts, cap_faces, cap_normals, _ = border_caps(data, 0.0, spacing, direction, cells=cells)
    assert len(cap_faces)
    # the caps lie on the volume's faces (within the padding's margin), their normals out of the volume
    upper = (np.asarray(data.shape) - 1) * np.asarray(spacing)
    on_a_face = np.isclose(cap_verts, 0.0, atol=1e-2) | np.isclose(cap_verts, upper, atol=1e-2)
    assert on_a_face.any(axis=1).all()
    all_verts = np.concatenate([verts, cap_verts])
    all_faces = np.concatenate([faces, cap_faces + len(verts)])
    assert open_edge_count(welded(all_verts, all_faces)) == 0
    # what they enclose is what export --closed's padded extraction encloses
    volume = finish_volume(data, spacing=spacing, name="ball", source="ball", gradient_direction=direction,
                           default_level=None)
    padded = closed_mesh(volume, 0.0, cells)
    assert open_edge_count(padded[1]) == 0
    assert measure_surface(all_verts, all_faces).volume == pytest.approx(measure_surface(*padded[:2]).volume,
                                                                         rel=2e-3)
    assert measure_surface(all_verts, all_faces).volume > 0   # outward-wound, caps included


def test_a_surface_inside_the_volume_has_no_caps():
    data = cut_ball((20.0, 20.0, 20.0))
    assert len(border_caps(data, 0.0)[1]) == 0


# --- render --closed and the viewer ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ball_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("closed") / "cut_ball.npy"
    np.save(path, cut_ball())
    return path


VIEW = ("--iso", "0", "--azimuth", "200", "--elevation", "20", "--size", "240x180")


@pytest.mark.gl
def test_render_closed_draws_the_cap_in_the_front_colour(ball_file, tmp_path):
    """Looking into the cut (from -x, a little above): where the open surface shows its inside (the back
    colour, orange), the closed one shows its cap (the front colour, blue)."""
    pictures = {}
    for closed in (False, True):
        out = tmp_path / f"ball{'-closed' * closed}.png"
        result = isoscope_here("render", ball_file, *VIEW, *(["--closed"] if closed else []), "--out", out)
        assert result.returncode == 0, result.stderr
        pictures[closed] = np.asarray(Image.open(out).convert("RGB")).astype(int)
    inside = pictures[False][..., 0] > pictures[False][..., 2] + 40     # orange: red over blue
    assert inside.sum() > 2000
    capped = pictures[True][inside]
    assert (capped[:, 2] > capped[:, 0]).mean() > 0.97                  # blue over red


@pytest.mark.gl   # held to what `isoscope render` says: it needs a GL context first
def test_render_closed_with_sharp_is_one_line(ball_file, tmp_path):
    result = isoscope_here("render", ball_file, "--iso", "0", "--sharp", "30", "--closed", "--out", tmp_path / "x.png")
    assert_one_line_error(result, "--closed")


@pytest.mark.parametrize("cells", ["cubes", "tetrahedra"])
def test_save_mesh_closed_at_the_border_is_watertight(gl_ctx, ball_file, tmp_path, cells):
    import trimesh

    from isoscope.viewer.ui.headless import HeadlessViewer
    viewer = HeadlessViewer((160, 120), ctx=gl_ctx)
    try:
        viewer.open(str(ball_file))
        viewer.state.levels.set_value(0.0)
        viewer.state.set_cells(cells)
        viewer.update()
        viewer.state.closed = True   # the panel's 'closed at the border'
        assert len(viewer.scene.drawn()) == 2   # the level and its caps
        save_mesh(viewer.scene, tmp_path / "ball.ply")
        viewer.state.closed = False
        assert len(viewer.scene.drawn()) == 1
        save_mesh(viewer.scene, tmp_path / "open.ply")
    finally:
        viewer.release()
    closed = trimesh.load(tmp_path / "ball.ply", process=True)
    assert closed.is_watertight and closed.volume > 0
    assert open_edge_count(np.asarray(closed.faces)) == 0
    half_ball = 2 / 3 * np.pi * RADIUS ** 3
    assert closed.volume == pytest.approx(half_ball, rel=0.03)
    assert not trimesh.load(tmp_path / "open.ply", process=True).is_watertight


@pytest.mark.gl   # held to what `isoscope render` says: it needs a GL context first
def test_a_saved_scene_keeps_closed_and_render_redraws_it(ball_file, tmp_path):
    scene_path, picture = tmp_path / "ball.json", tmp_path / "ball.png"
    result = isoscope_here("render", ball_file, *VIEW, "--closed", "--out", picture, "--save-scene", scene_path)
    assert result.returncode == 0, result.stderr
    import json
    assert json.loads(scene_path.read_text())["mesh"]["closed"] is True
    again = tmp_path / "again.png"
    result = isoscope_here("render", scene_path, "--out", again)
    assert result.returncode == 0, result.stderr
    assert np.array_equal(np.asarray(Image.open(again)), np.asarray(Image.open(picture)))
    result = isoscope_here("render", scene_path, "--closed", "--out", again)
    assert_one_line_error(result, "--closed")


def test_export_closed_with_sharp_features_is_watertight_with_its_corners(tmp_path):
    """`export --closed --sharp`: the padded extraction with sharp features (closed_mesh, the viewer's and
    export's one door): a box cut by the volume's x = 0 face is closed there, and its corners inside are kept
    (sharp features place them on the corner, where plain cubes round them off)."""
    import trimesh
    x, y, z = np.indices((24, 24, 24)).astype(np.float32)
    box = np.minimum.reduce([8.5 - x, x + 8.5, 8.5 - np.abs(y - 12), 8.5 - np.abs(z - 12)])   # x in -8.5..8.5
    np.save(tmp_path / "box.npy", box.astype(np.float32))
    for extra, name in (((), "plain.ply"), (("--sharp", "30"), "sharp.ply")):
        result = isoscope_here("export", tmp_path / "box.npy", "--iso", "0", "--closed", *extra, "--out",
                               tmp_path / name)
        assert result.returncode == 0, result.stderr
    sharp, plain = (trimesh.load(tmp_path / name, process=True) for name in ("sharp.ply", "plain.ply"))
    assert sharp.is_watertight and plain.is_watertight
    assert open_edge_count(np.asarray(sharp.faces)) == 0
    want = 8.5 * 17 * 17   # the kept half of the box: x 0..8.5, y and z 3.5..20.5
    assert sharp.volume == pytest.approx(want, rel=0.01)
    assert abs(sharp.volume - want) < abs(plain.volume - want)   # the corners kept, not cut off
    corner = np.array([8.5, 20.5, 20.5])
    assert np.linalg.norm(sharp.vertices - corner, axis=1).min() < 0.1 < np.linalg.norm(plain.vertices - corner,
                                                                                          axis=1).min()
