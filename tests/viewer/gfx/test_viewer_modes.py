"""The viewer's mesh modes (cells, smoothing, sharp features) and label maps, through ViewerState as the
panel and the viewer's flags use them, drawn by its GPU scene: what is drawn and saved must be what the
API makes."""
from __future__ import annotations

import nibabel
import numpy as np
import pytest
import trimesh
from scipy.ndimage import map_coordinates
from support.command import assert_one_line_error, isoscope_batch

import isoscope as api
from isoscope.api import outward_marching_cubes
from isoscope.options import MeshOptionsError
from isoscope.viewer.gfx.saving import save_mesh
from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume


@pytest.fixture
def viewer(gl_ctx):
    viewer = HeadlessViewer((320, 240), ctx=gl_ctx)
    yield viewer
    viewer.release()


def drawn_triangles(viewer):
    viewer.update()   # the frame in which the GPU follows the state
    return [mesh.n_triangles for mesh in viewer.scene.stats.meshes]


def test_tetrahedra_apply_to_every_level_without_a_new_upload(viewer):
    volume = open_volume("torus", resolution=32)
    viewer.show_levels(volume, [0.0, 0.1])
    state = viewer.state
    cubes = drawn_triangles(viewer)
    extractor = viewer.scene.extractor
    assert state.set_cells("tetrahedra")
    assert drawn_triangles(viewer) != cubes and viewer.scene.extractor is extractor   # the same resident volume
    expected = [len(api.marching_tetrahedra(volume.checked, level, spacing=volume.spacing,
                                            gradient_direction=volume.gradient_direction)[1]) for level in (0.0, 0.1)]
    assert drawn_triangles(viewer) == expected
    assert all(t > 2 * c for t, c in zip(expected, cubes))
    assert state.set_cells("cubes") and drawn_triangles(viewer) == cubes
    with pytest.raises(MeshOptionsError, match="cubes"):
        state.set_cells("hexahedra")
    assert state.mesh_options.cells == "cubes" and drawn_triangles(viewer) == cubes
    # One source for the options: the GPU surface keeps none of its own.
    assert not {"cells", "smooth", "sharp"} & set(vars(viewer.scene.surface))


def test_smoothing_moves_every_level_onto_its_own_level_set(viewer, tmp_path):
    volume = open_volume("metaballs", resolution=40)
    viewer.show_levels(volume, [0.5, 0.8])
    state = viewer.state
    assert state.set_smooth(3)
    viewer.update()
    data = volume.data.astype(np.float64)
    for mesh, level in zip(viewer.scene.stats.meshes, (0.5, 0.8)):
        verts = mesh.read()[0]
        values = map_coordinates(data, (verts / np.asarray(volume.spacing)).T, order=1, mode="nearest")
        assert np.abs(values - level).max() <= 1e-3 * (data.max() - data.min())
    state.levels.select(0)
    viewer.update()
    save_mesh(viewer.scene, tmp_path / "smooth.ply")
    saved = trimesh.load(tmp_path / "smooth.ply", process=False)
    expected = api.marching_cubes(volume.checked, 0.5, spacing=volume.spacing, smooth=3)
    assert len(saved.faces) == len(expected[1])
    with pytest.raises(ValueError, match="smooth"):
        state.set_smooth(-1)
    assert state.mesh_options.smooth == 3


def test_sharp_features_are_drawn_and_saved_as_the_api_makes_them(viewer, tmp_path):
    volume = open_volume("box", resolution=24)
    viewer.show(volume)
    state, scene = viewer.state, viewer.scene
    plain = scene.stats.n_triangles
    assert state.set_sharp(30)
    viewer.update()
    verts, faces, _, _ = api.marching_cubes(volume.checked, state.iso, spacing=volume.spacing,
                                            gradient_direction=volume.gradient_direction, sharp_features=30)
    assert scene.stats.n_triangles == len(faces) and len(faces) != plain
    save_mesh(scene, tmp_path / "box.stl")
    saved = trimesh.load(tmp_path / "box.stl", process=False)
    assert len(saved.faces) == len(faces)
    # Smoothing or tetrahedra would undo the features: refused in the rule's words, and the sharp mesh stays.
    with pytest.raises(MeshOptionsError, match="smoothing would round off the sharp features"):
        state.set_smooth(2)
    with pytest.raises(MeshOptionsError, match="not with tetrahedra"):
        state.set_cells("tetrahedra")
    assert (state.mesh_options.smooth, state.mesh_options.cells) == (0, "cubes")
    viewer.update()
    assert scene.stats.n_triangles == len(faces)
    assert state.set_sharp(None)
    viewer.update()
    assert scene.stats.n_triangles == plain


def test_sharp_features_at_rest_are_made_on_a_worker_while_the_plain_mesh_shows(viewer, tmp_path):
    # The slider coming to rest: the feature step (a second or more on a scan) runs on a worker thread
    # and the window keeps drawing the plain mesh; the next frames bring the sharp one in.  A newer
    # level drops an older level's result; saving waits for it.
    import time
    volume = open_volume("box", resolution=24)
    viewer.show(volume)
    state, scene = viewer.state, viewer.scene
    assert state.set_sharp(30)  # an explicit option: made at once
    viewer.update()
    lo, hi = state.value_range

    def meshes(iso):
        kwargs = dict(spacing=volume.spacing, gradient_direction=volume.gradient_direction)
        return (api.marching_cubes(volume.checked, iso, **kwargs),
                api.marching_cubes(volume.checked, iso, sharp_features=30, **kwargs))

    # Below the box's own level its offsets are smaller boxes, with edges (above, they round off).
    first, second = state.iso - 0.02 * (hi - lo), state.iso - 0.04 * (hi - lo)
    state.iso = first
    scene.update(0.0)
    state.iso = second  # before the first level's features are in
    scene.update(0.0)
    plain, sharp = meshes(second)
    assert len(sharp[1]) != len(plain[1])  # the level has features
    assert scene.surface.sharp_pending and scene.stats.n_triangles == len(plain[1])
    deadline = time.monotonic() + 60
    while scene.surface.sharp_pending and time.monotonic() < deadline:
        time.sleep(0.01)
        scene.update(0.0)
    assert not scene.surface.sharp_pending and scene.stats.n_triangles == len(sharp[1])
    np.testing.assert_allclose(scene.surface.shown.read_mesh()[0], sharp[0], atol=1e-5)

    state.iso = first
    scene.update(0.0)
    assert scene.surface.sharp_pending
    save_mesh(scene, tmp_path / "box.stl")  # waits for the features
    assert len(trimesh.load(tmp_path / "box.stl", process=False).faces) == len(meshes(first)[1][1])
    assert not scene.surface.sharp_pending and scene.stats.n_triangles == len(meshes(first)[1][1])


def test_a_failed_extraction_or_feature_step_leaves_a_drawable_plain_mesh(viewer, monkeypatch):
    # A level whose outputs cannot be allocated while the last level's features are still on the
    # worker: the frame after draws (the extractor's empty mesh, not the released buffers), and the
    # late features do not come back.  A feature step that fails: one message, the plain mesh stays.
    import time

    import moderngl

    import isoscope.gpu.sharp_features as sharp_features
    viewer.show(open_volume("box", resolution=24))
    state, scene = viewer.state, viewer.scene
    assert state.set_sharp(30)
    viewer.update()
    lo, hi = state.value_range
    step = sharp_features._step
    monkeypatch.setattr(sharp_features, "_step", lambda *args: (time.sleep(0.3), step(*args))[1])
    state.iso -= 0.02 * (hi - lo)
    scene.update(0.0)
    assert scene.surface.sharp_pending
    extractor = scene.surface.extractor

    vertices = extractor.outputs.buffers["vertices"]   # its GrowableBuffer: the next growth finds no memory

    class NoMemory:
        def buffer(self, reserve):
            if reserve > vertices.minimum:
                raise moderngl.Error("out of memory")
            return extractor.ctx.buffer(reserve=reserve)
    vertices.release()   # as a failed growth leaves it: the old buffer already gone
    monkeypatch.setattr(vertices, "ctx", NoMemory())
    state.iso -= 0.01 * (hi - lo)
    scene.update(0.0)
    assert "could not allocate" in state.error and not scene.surface.sharp_pending
    viewer.render()  # no released buffer is drawn
    time.sleep(0.5)
    scene.update(0.0)
    assert scene.stats.n_triangles == 0  # the dropped step's mesh did not come back
    monkeypatch.undo()

    def broken(*args):
        raise IndexError("a bug in the feature step")
    monkeypatch.setattr(sharp_features, "_step", broken)
    state.iso -= 0.01 * (hi - lo)
    scene.update(0.0)
    plain = scene.stats.n_triangles
    deadline = time.monotonic() + 30
    while scene.surface.sharp_pending and time.monotonic() < deadline:
        time.sleep(0.01)
        scene.update(0.0)
    assert "sharp features failed" in state.error and "IndexError" in state.error and "\n" not in state.error
    assert scene.stats.n_triangles == plain > 0
    viewer.render()


def test_a_feature_step_stops_when_asked(gl_ctx):
    import threading

    from isoscope.core.sharp.features import Stopped, sharpen, signed_field
    volume = open_volume("box", resolution=24)
    mesh = outward_marching_cubes(volume.checked, volume.default_level, gradient_direction=volume.gradient_direction)
    field = signed_field(volume.data, volume.gradient_direction == "descent")
    stop = threading.Event()
    assert len(sharpen(mesh, field, (1, 1, 1), 30, stop=stop)[0]) > len(mesh[0])  # not set: it runs
    stop.set()
    with pytest.raises(Stopped):
        sharpen(mesh, field, (1, 1, 1), 30, stop=stop)


@pytest.fixture
def two_labels(tmp_path):
    labels = np.zeros((30, 28, 26), np.uint8)
    labels[4:14, 5:20, 4:20] = 1
    labels[14:25, 5:20, 4:20] = 7      # touching label 1 along a face
    path = tmp_path / "seg.nii.gz"
    nibabel.save(nibabel.Nifti1Image(labels, np.diag([0.8, 0.9, 1.1, 1.0])), path)
    return path


def test_a_label_map_shows_one_coloured_surface_per_label(viewer, two_labels, tmp_path):
    volume = open_volume(str(two_labels))
    state, scene = viewer.state, viewer.scene
    viewer.show(volume)
    assert state.show_labels(volume)
    assert scene.stats.label_counts() == (0, 0, 0)   # asked for; the surfaces are made in the frame, not here
    surfaces = api.label_surfaces(volume.data, spacing=volume.spacing)
    assert drawn_triangles(viewer) == [len(surfaces[label][1]) for label in (1, 7)]
    colors = [look.color for look in scene.stats.looks]
    assert colors[0] != colors[1]
    both = viewer.render()
    assert scene.stats.label_counts() == (2, sum(len(s[0]) for s in surfaces.values()),
                                    sum(len(s[1]) for s in surfaces.values()))
    state.labels.set_visible(7, False)
    assert drawn_triangles(viewer) == [len(surfaces[1][1])]
    assert scene.stats.label_counts() == (1, len(surfaces[1][0]), len(surfaces[1][1]))   # the stats: what is drawn
    assert not np.array_equal(viewer.render(), both)
    with pytest.raises(ViewerError, match="no label 3"):
        state.labels.set_visible(3, False)
    # Save writes what is shown: the visible label, one file each (STL), in the file's world space.
    save_mesh(scene, tmp_path / "out.stl")
    assert (tmp_path / "out_label1.stl").exists() and not (tmp_path / "out_label7.stl").exists()
    state.labels.set_visible(7, True)
    save_mesh(scene, tmp_path / "all.ply")   # PLY carries colours: one file
    mesh = trimesh.load(tmp_path / "all.ply", process=False)
    assert len(mesh.faces) == sum(len(s[1]) for s in surfaces.values())
    assert len(np.unique(mesh.visual.vertex_colors[:, :3], axis=0)) == 2
    state.labels.hide()
    assert len(drawn_triangles(viewer)) == 1     # back to the isosurface


HISTOGRAM_RGB = (230, 179, 0)   # imgui's default PlotHistogram colour (0.90, 0.70, 0.00)


def histogram_pixels(image):
    return int((np.abs(image.astype(int) - HISTOGRAM_RGB) <= 3).all(axis=2).sum())


def test_a_label_map_takes_the_place_of_the_iso_value_section(gl_ctx, two_labels):
    """The iso value does nothing to a label map: while one is on show the panel has no iso slider and
    no value histogram; back to the isosurface, both return."""
    viewer = HeadlessViewer((480, 900), ctx=gl_ctx)
    try:
        volume = open_volume(str(two_labels))
        viewer.show(volume)
        assert histogram_pixels(viewer.render(panel=True)) > 20
        assert viewer._panel.iso_slider_box is not None
        assert viewer.state.show_labels(volume)
        assert histogram_pixels(viewer.render(panel=True)) == 0
        assert viewer._panel.iso_slider_box is None
        viewer.state.labels.hide()
        assert histogram_pixels(viewer.render(panel=True)) > 20
    finally:
        viewer.release()


def test_a_volume_without_labels_is_refused_and_the_view_stays(viewer):
    state = viewer.state
    viewer.show(open_volume("sphere", resolution=20))
    before = drawn_triangles(viewer)
    with pytest.raises(ValueError, match="fractional values"):
        state.show_labels(open_volume("sphere", resolution=20))
    with pytest.raises(ValueError, match="not a label map"):
        state.show_labels()
    assert not state.labels and drawn_triangles(viewer) == before


def test_the_viewer_takes_the_mode_flags_and_refuses_bad_pairs(x_display, two_labels, monkeypatch):
    monkeypatch.setenv("DISPLAY", x_display)
    # The windows opened one after another by one process of their own (on the Xvfb display).
    *opened, sharp, labels = isoscope_batch(
        *([*flags, "--frames", "2"] for flags in (["torus", "--tetrahedra", "--smooth", "2"], ["box", "--sharp", "30"],
                                                  [two_labels, "--labels"], ["box", "--tetrahedra", "--sharp", "30"],
                                                  ["sphere", "--labels"])))
    for result in opened:
        assert result.returncode == 0, result.stderr
    assert_one_line_error(sharp, "sharp")
    assert_one_line_error(labels, "label")


def test_a_volume_that_looks_like_a_label_map_is_offered_as_one(viewer, two_labels):
    from isoscope.labels import label_count_hint
    assert label_count_hint(np.array([[[0, 3, 3], [-2, 0, 9]]], np.int16)) == 3
    assert label_count_hint(np.arange(256, dtype=np.uint8).reshape(4, 8, 8)) == 0   # a scan: too many values
    assert label_count_hint(np.zeros((2, 2, 2), np.float32)) == 0
    viewer.show(open_volume(str(two_labels)))
    assert viewer.state.label_hint == 2 and not viewer.state.labels   # offered, not switched
    viewer.show(open_volume("bucky"))
    assert viewer.state.label_hint == 0


def test_the_pointer_can_rest_on_every_part_of_the_panel(gl_ctx, two_labels):
    """Hovering shows tooltips: sweep the pointer down the panel's widget columns, with two iso levels
    and with a label map on show (a tooltip's call must not fail), resting at each place for the frame
    in which its tooltip shows."""
    from imgui_bundle import imgui
    viewer = HeadlessViewer((480, 1200), ctx=gl_ctx)
    try:
        viewer.show_levels(open_volume("torus", resolution=20), [0.0, 0.1])
        viewer.render(panel=True)
        io, style = imgui.get_io(), imgui.get_style()
        # A tooltip shows once the pointer has rested (imgui's delays, 0.15 s at 60 frames a second): with no
        # delay, in the second frame at a place.
        style.hover_delay_short = style.hover_stationary_delay = 0.0

        def sweep() -> int:
            """Places in which a tooltip showed. Each frame lays the panel out as the window's frames do;
            its pixels are drawn once, after the sweep."""
            shown = 0
            x0, y0, width, height = viewer._panel.box
            for y in np.arange(y0 + 4, y0 + height, 17.0):  # under a widget row (~23 px): each row is hit
                for x in (x0 + 18, x0 + 42, x0 + 120):
                    io.add_mouse_pos_event(float(x), float(y))
                    for _ in range(2):
                        viewer._layout_panel()
                        imgui.end_frame()
                    tip = imgui.internal.find_window_by_name("##Tooltip_00")
                    shown += tip is not None and tip.active
            viewer.render(panel=True)
            return shown

        io.add_mouse_pos_event(160.0, 8.0)
        assert sweep() >= 20
        viewer.show(open_volume(str(two_labels)))
        viewer.state.show_labels()
        assert sweep() >= 10
    finally:
        viewer.release()


def test_a_level_that_cannot_be_kept_is_refused_in_one_line_and_nothing_changes(viewer, monkeypatch):
    viewer.show_levels(open_volume("torus", resolution=24), [0.0])
    state = viewer.state
    before = (len(state.levels), state.levels.selected, drawn_triangles(viewer))

    def out_of_memory(*args, **kwargs):
        raise ValueError("the mesh needs 2 GiB of GPU memory; lower the resolution")
    monkeypatch.setattr(viewer.scene.surface, "extract", out_of_memory)
    state.iso = 0.05   # moved, not yet extracted: keeping the level needs an extraction
    state.levels.add(0.1)
    viewer.scene.update(0.0)   # the frame in which the GPU would keep the level: it cannot
    assert state.error == "the mesh needs 2 GiB of GPU memory; lower the resolution"
    assert (len(state.levels), state.levels.selected) == before[:2]
