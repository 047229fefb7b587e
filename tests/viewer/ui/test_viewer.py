"""ViewerState, its GPU scene and the imgui panel, driven the way the window drives them, rendered through EGL."""
from __future__ import annotations

import json

import numpy as np
import pytest
from support.panel import assert_marker_at, click_histogram

from isoscope.viewer.gfx.saving import save_mesh
from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.model.recent import RecentFiles
from isoscope.viewer.model.style import SurfaceStyle
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

SIZE = (480, 360)


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    headless.show(open_volume("sphere", resolution=32), iso=0.0)
    yield headless
    headless.release()


def test_changing_the_iso_through_the_state_re_extracts_once(viewer):
    state, scene = viewer.state, viewer.scene
    triangles_before = scene.stats.n_triangles
    assert scene.update(0.0) is False          # nothing moved: no extraction
    state.iso = 0.25
    assert scene.extractor.level != pytest.approx(0.25)   # the state changes; the GPU follows in the frame
    assert scene.update(0.0) is True
    assert scene.extractor.level == pytest.approx(0.25)
    assert scene.stats.n_triangles > triangles_before
    assert scene.update(0.0) is False


def test_iso_is_kept_inside_the_range_and_keys_step_by_fractions(viewer):
    state = viewer.state
    low, high = state.value_range
    assert (low, high) == state.volume.value_range   # the volume's range, not the extractor's
    state.iso = high + 100
    assert state.iso == high
    state.iso = low + 0.5 * (high - low)
    state.levels.nudge(+0.01)
    assert state.iso == pytest.approx(low + 0.51 * (high - low))
    state.levels.nudge(-0.10)
    assert state.iso == pytest.approx(low + 0.41 * (high - low))


def test_animation_sweeps_the_iso_through_the_range(viewer):
    state = viewer.state
    low, high = state.value_range
    state.levels.toggle_animation()
    seen = []
    for _ in range(12):
        viewer.scene.update(0.5)   # 6 s period: 12 half-second frames are one sweep up and down
        seen.append(state.iso)
    assert low < min(seen) < low + 0.1 * (high - low)
    assert high - 0.1 * (high - low) < max(seen) < high
    state.levels.toggle_animation()
    frozen = state.iso
    viewer.scene.update(0.5)
    assert state.iso == frozen


BACKGROUND = np.round(255 * np.array(SurfaceStyle().background)).astype(int)


def scene_pixels(image):
    """Where something other than the background colour is drawn."""
    return (np.abs(image.astype(int) - BACKGROUND) > 3).any(axis=2)


def test_panel_draws_over_its_corner_only(gl_ctx):
    size = (960, 600)  # wide enough that the scene fits beside the panel
    viewer = HeadlessViewer(size, ctx=gl_ctx)
    try:
        viewer.show(open_volume("sphere", resolution=32), iso=0.0)
        without_panel = viewer.render(panel=False)
        with_panel = viewer.render(panel=True)
        x, y, width, height = (int(round(v)) for v in viewer._panel.box)
    finally:
        viewer.release()
    assert (x, y) == (8, 8) and 200 < width < size[0] // 2 and 100 < height <= size[1]
    inside = np.zeros(size[::-1], bool)
    inside[y:y + height, x:x + width] = True
    changed = np.abs(with_panel.astype(int) - without_panel.astype(int)).max(axis=2) > 0
    assert changed[inside].mean() > 0.5, "the panel is not drawn in its box"
    # Outside its box the panel draws nothing: the scene is all there, moved right to centre in
    # the uncovered part of the window.
    scene_before, scene_after = scene_pixels(without_panel), scene_pixels(with_panel)
    assert scene_after[~inside].sum() == pytest.approx(scene_before.sum(), rel=0.1)
    left = x + width
    centre_after = np.nonzero(scene_after[:, left:])[1].mean() + left
    assert centre_after == pytest.approx((left + size[0]) / 2, abs=0.05 * size[0])


def find_slider_grab(image):
    """Centre (x, y) of the iso slider's grab: imgui's default SliderGrab colour (0.24, 0.52, 0.88)."""
    rows, cols = np.nonzero((np.abs(image.astype(int) - [61, 133, 224]) <= 3).all(axis=2))
    assert len(rows) > 20, "no slider grab in the image"
    return cols.mean(), rows.mean()


def test_panel_slider_follows_the_iso_value(viewer):
    def slider_grab_column(image):
        return find_slider_grab(image)[0]

    low, high = viewer.state.value_range
    viewer.state.iso = low + 0.1 * (high - low)
    left = slider_grab_column(viewer.render(panel=True))
    viewer.state.iso = low + 0.9 * (high - low)
    right = slider_grab_column(viewer.render(panel=True))
    assert right - left > 150


def test_dragging_the_panel_slider_with_the_mouse_re_extracts(viewer, monkeypatch):
    from imgui_bundle import imgui  # the headless panel gets its mouse from imgui's io, as GLFW feeds it

    low, high = viewer.state.value_range
    viewer.state.iso = low + 0.5 * (high - low)
    x, y = find_slider_grab(viewer.render(panel=True))
    triangles_before = viewer.scene.stats.n_triangles
    # No extraction while the panel lays itself out: only in the frame's update after it.
    extract, draw, laying_out = viewer.scene.surface.extract, viewer._panel.draw, []

    def extract_outside_layout(*args, **kwargs):
        assert not laying_out, "the panel's layout extracted"
        return extract(*args, **kwargs)

    def layout(*args):
        laying_out.append(True)
        try:
            draw(*args)
        finally:
            laying_out.clear()
    monkeypatch.setattr(viewer.scene.surface, "extract", extract_outside_layout)
    monkeypatch.setattr(viewer._panel, "draw", layout)
    io = imgui.get_io()
    io.add_mouse_pos_event(x, y)
    viewer.render(panel=True)
    io.add_mouse_button_event(0, True)
    viewer.render(panel=True)
    io.add_mouse_pos_event(x + 60, y)
    viewer.render(panel=True)
    io.add_mouse_button_event(0, False)
    viewer.render(panel=True)
    assert viewer.state.iso > low + 0.6 * (high - low)
    assert viewer.scene.extractor.level == pytest.approx(viewer.state.iso)
    assert viewer.scene.stats.n_triangles != triangles_before


def error_pixels(image, panel_right):
    r, g, b = (image[:, :panel_right, k].astype(int) for k in range(3))
    return int(((r > 200) & (g < 140) & (b < 140)).sum())


def test_bad_file_shows_its_error_in_the_panel_and_keeps_the_volume(viewer, tmp_path):
    state = viewer.state
    volume, extractor, iso = state.volume, viewer.scene.extractor, state.iso
    clean = viewer.render(panel=True)

    broken = tmp_path / "broken.npy"
    broken.write_bytes(b"this is not a numpy file")
    with pytest.raises(ValueError, match="broken.npy"):
        viewer.open(str(broken))
    state.opening.open(str(broken))       # as the panel asks: the answer comes in a frame, shown in the panel
    assert state.opening.loading.done(wait_s=60)
    viewer.render(panel=True)              # the frame that takes the answer: after its panel's layout
    shown = viewer.render(panel=True)      # the next frame's panel shows it
    assert state.error and "\n" not in state.error and "broken.npy" in state.error
    assert state.volume is volume and viewer.scene.extractor is extractor and state.iso == iso
    panel_right = int(viewer._panel.covered_width)
    assert error_pixels(shown, panel_right) > 50 + error_pixels(clean, panel_right)

    viewer.open("sphere")   # the next good volume clears the error
    assert state.error is None


def test_opening_a_file_adds_it_to_recent_files(gl_ctx, tmp_path):
    recent_path = tmp_path / "config" / "recent.json"
    viewer = HeadlessViewer((64, 64), ctx=gl_ctx)
    viewer.state.recent = RecentFiles(recent_path)
    try:
        data = np.random.default_rng(1).normal(size=(12, 10, 8)).astype(np.float32)
        path = tmp_path / "noise.npy"
        np.save(path, data)
        viewer.open(str(path))
        assert viewer.state.volume.data.shape == (12, 10, 8)
        assert json.loads(recent_path.read_text()) == [str(path.resolve())]
        assert RecentFiles(recent_path).paths == [str(path.resolve())]
    finally:
        viewer.release()


def test_expression_box_opens_an_implicit_function(viewer):
    viewer.open("expr:x*x + y*y + z*z - 0.25; res=24")
    assert viewer.state.volume.data.shape == (24, 24, 24)
    assert viewer.scene.stats.n_triangles > 0


@pytest.mark.parametrize("formula", ["+".join(["x"] * 999), "*".join(["x"] * 999), "-" * 1500 + "x",
                                     "(" * 900 + "x" + ")" * 900, "sin(" * 400 + "x" + ")" * 400])
def test_a_hostile_expression_typed_in_the_panel_keeps_the_window(viewer, formula):
    """Issue 22: ~1000 terms typed into the panel closed the viewer (RecursionError). Each opens, or is
    refused in one line with the last good volume still on show."""
    state = viewer.state
    volume = state.volume
    state.opening.open(f"expr:{formula}; res=8")   # as the panel's expr box asks
    viewer.render()
    if state.error is None:
        assert state.volume.data.shape == (8, 8, 8)
    else:
        assert "\n" not in state.error and state.volume is volume
    viewer.open("sphere")


def test_object_side_toggle_reverses_the_normals_and_keeps_the_view(viewer):
    state = viewer.state
    serial, iso = state.volume_serial, state.iso
    assert state.gradient_direction == "ascent"             # the built-in sphere is a signed distance
    _, _, outward, _ = viewer.scene.extractor.read_mesh()
    assert state.set_gradient_direction("descent")
    viewer.render()
    assert state.volume.gradient_direction == "descent"
    assert (state.volume_serial, state.iso) == (serial, iso)  # no refit, same level
    _, _, inward, _ = viewer.scene.extractor.read_mesh()
    np.testing.assert_allclose(inward, -outward, atol=1e-6)
    assert state.set_gradient_direction("descent") is False   # already so: nothing re-extracted
    with pytest.raises(ViewerError, match="descent, ascent"):
        state.set_gradient_direction("inside")


def test_a_volume_read_in_the_background_reports_progress_then_shows(viewer, tmp_path):
    """Files open on a worker thread: the panel's bar follows the loader; the upload happens in update()."""
    path = tmp_path / "ramp.npy"
    np.save(path, np.broadcast_to(np.arange(192, dtype=np.float32), (256, 256, 192)))  # 48 MiB: read in slabs
    state = viewer.state
    request = state.opening.open(str(path))
    pending = state.opening.loading
    assert pending.request_id == request and pending.done(wait_s=60)
    assert pending.message != f"opening {path}" and 0 < pending.fraction <= 1  # the loader reported
    assert pending.response.request_id == request          # the answer carries the request's id
    assert state.volume.name != "ramp"                  # not shown until the main thread takes it
    viewer.render()                                      # a frame: the scene uploads and extracts it
    assert state.opening.loading is None and state.error is None
    assert state.volume.data.shape == (256, 256, 192) and viewer.scene.stats.n_triangles > 0
    assert str(path.resolve()) in state.recent.paths


def test_a_bad_file_read_in_the_background_keeps_the_volume(viewer, tmp_path):
    state = viewer.state
    before = state.volume
    bad = tmp_path / "broken.npy"
    bad.write_bytes(b"\x93NUMPY garbage")
    state.opening.open(str(bad))
    assert state.opening.loading.done(wait_s=60)
    viewer.render()
    assert state.volume is before and viewer.scene.extractor is not None
    assert state.error and "broken.npy" in state.error and "\n" not in state.error


def test_a_newer_open_request_wins_over_an_older_slower_one(viewer):
    """Each read answers with its request's id; the answer to an older request that comes in after a
    newer one's is stale, and dropped: the volume asked for last stays on show."""
    import threading

    from isoscope.viewer.model.opening import read_for_viewer
    state, release = viewer.state, threading.Event()

    def slow(spec, progress=None):
        release.wait(60)
        return read_for_viewer(open_volume, spec, {"resolution": 16}, state.budget, progress=progress)
    old = state.jobs.submit("open", slow, "gyroid")
    new = state.opening.open("torus", resolution=16)
    assert new > old and state.opening.loading.request_id == new
    assert state.opening.loading.done(wait_s=60)
    viewer.render()
    assert state.volume.name == "torus:16"
    release.set()
    (stale,) = [job for job in state.jobs._running if job.request_id == old]
    assert stale.done(wait_s=60) and stale.response.request_id == old
    assert stale.response.value.volume.name == "gyroid:16"   # it did answer ...
    viewer.render()
    assert state.volume.name == "torus:16" and state.error is None   # ... and was dropped


def test_progress_bar_is_drawn_while_loading(viewer, tmp_path):
    """The panel draws a bar while a load is pending: pixels in the panel differ from a frame without."""
    import threading
    state = viewer.state
    idle = viewer.render(panel=True)
    release = threading.Event()

    def stalled(spec, progress=None):   # a read that has not finished: what the panel sees mid-read
        progress(0.5, "reading ramp")
        release.wait(60)
        raise OSError("not read")
    state.jobs.submit("open", stalled, "ramp")
    loading = viewer.render(panel=True)
    release.set()
    state.opening.loading.done(wait_s=60)
    viewer.render()
    assert np.abs(loading.astype(int) - idle.astype(int)).max(axis=2)[:, :300].sum() > 0


def test_a_dragged_value_shows_a_coarse_preview_then_the_full_mesh_at_rest(gl_ctx, monkeypatch):
    from support.mesh_checks import assert_same_mesh

    import isoscope.viewer.gfx.surface as surface_module
    from isoscope.cpu.cubes import marching_cubes_reference
    from isoscope.viewer.gfx.scene import REST_S, GpuScene
    from isoscope.viewer.model.state import ViewerState

    monkeypatch.setattr(surface_module, "PREVIEW_TRIANGLES", 3000)  # a small volume's mesh is "big"
    state = ViewerState()
    scene = GpuScene(gl_ctx, state, previews=True)
    try:
        volume = open_volume("gyroid", resolution=48)
        scene.show(volume, 0.0)
        full = scene.stats.n_triangles
        assert full > 4 * 3000 and scene.stats.preview_step == 1
        low, high = state.value_range
        drag = [low + f * (high - low) for f in (0.45, 0.47, 0.49, 0.51)]

        state.iso = drag[0]
        scene.update(0.04)                 # the first change of a drag is a preview too (no stall as it starts)
        assert scene.stats.preview_step > 1 and scene.stats.n_triangles < full / 2
        for value in drag[1:]:             # changing frame after frame: a drag
            state.iso = value
            assert scene.update(0.04)
            step = scene.stats.preview_step
            assert step > 1 and scene.stats.n_triangles < full / 2
        # The preview is exactly the mesh of every step-th sample, in the same world units.
        sign = 1.0 if volume.gradient_direction == "descent" else -1.0
        coarse = volume.data[::step, ::step, ::step].astype(np.float32)
        assert_same_mesh(scene.stats.meshes[0].read(),
                         marching_cubes_reference(coarse, drag[-1], tuple(s * step for s in volume.spacing),
                                                  descent=sign > 0))

        assert scene.update(REST_S / 2) is False and scene.stats.preview_step == step  # not rested yet
        assert scene.update(REST_S / 2) is False and scene.stats.preview_step == step  # rested: the status line says
        assert state.message.startswith("full resolution: extracting 48x48x48")  # the full mesh is coming,
        assert scene.update(0.01) is False and scene.stats.preview_step == step        # a frame shows that,
        assert scene.update(0.01) is True and scene.stats.preview_step == 1            # and the next makes it
        stats = scene.stats
        assert state.message == f"full resolution: {stats.n_triangles:,} triangles in {stats.extract_ms:.0f} ms"
        assert scene.extractor.level == drag[-1]
        assert scene.stats.n_triangles == len(marching_cubes_reference(volume.data.astype(np.float32), drag[-1],
                                                                 volume.spacing, descent=sign > 0)[1])
        assert scene.update(1.0) is False                                        # and stays
    finally:
        scene.release()


def test_headless_renders_never_show_a_preview(viewer, monkeypatch):
    import isoscope.viewer.gfx.surface as surface_module
    monkeypatch.setattr(surface_module, "PREVIEW_TRIANGLES", 10)
    state = viewer.state
    for value in (0.1, 0.2, 0.3):
        state.iso = value
        viewer.render()
        assert viewer.scene.stats.preview_step == 1 and viewer.scene.extractor.level == pytest.approx(value)


def test_value_histogram_counts_every_sample_on_a_log_scale():
    from isoscope.viewer.model.histogram import BINS, value_histogram
    data = np.zeros((10, 10, 10), np.uint8)
    data[:5] = 200                                   # 500 samples at 200, 500 at 0
    data[0, 0, 0] = 100
    counts = np.expm1(value_histogram(data, (0.0, 200.0)).astype(np.float64))
    assert len(counts) == BINS and round(counts.sum()) == 1000
    assert round(counts[0]) == 500 and round(counts[-1]) == 499 and round(counts[BINS // 2]) == 1


def test_histogram_marks_the_level_and_a_click_on_it_sets_the_level(gl_ctx):
    viewer = HeadlessViewer((900, 700), ctx=gl_ctx)
    try:
        viewer.show(open_volume("bucky"), iso=64)
        state, colour = viewer.state, viewer.state.style.front_color
        for level in (64.0, 190.0):
            state.iso = level
            image = viewer.render(panel=True)
            assert_marker_at(image, viewer._panel.histogram_box, colour, level, state.value_range)
        click_histogram(viewer, 0.25)   # a press a quarter of the way across sets the level there
        low, high = state.value_range
        assert state.iso == pytest.approx(low + 0.25 * (high - low), abs=0.01 * (high - low))
        assert viewer.scene.extractor.level == pytest.approx(state.iso)
    finally:
        viewer.release()


def test_save_mesh_writes_the_surface_on_show_in_the_format_of_its_name(viewer, tmp_path):
    from support.mesh_checks import assert_closed_manifold, read_ply
    state, scene = viewer.state, viewer.scene
    state.saving.request_save(tmp_path / "shown.ply")   # as the panel's save dialog asks: written in the frame
    viewer.render()
    verts, normals, _, faces = read_ply(tmp_path / "shown.ply")
    assert len(faces) == scene.stats.n_triangles > 100 and len(verts) == scene.stats.n_vertices
    np.testing.assert_array_equal(faces, scene.extractor.read_mesh()[1])
    assert_closed_manifold(faces)
    assert "mesh saved" in state.message and str(tmp_path / "shown.ply") in state.message
    # A bad name: one line (raised, or in the panel), nothing written, the viewer as it was.
    with pytest.raises(ValueError, match=r"\.ply, \.obj, \.stl, \.glb, \.off"):
        save_mesh(scene, tmp_path / "shown.vtk")
    state.saving.request_save(tmp_path / "shown.vtk")
    viewer.render()
    assert ".ply, .obj, .stl, .glb, .off" in state.error and "\n" not in state.error
    assert not (tmp_path / "shown.vtk").exists()
