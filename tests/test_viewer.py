"""ViewerState and the imgui panel, driven the way the window drives them, rendered through EGL."""
from __future__ import annotations

import json

import numpy as np
import pytest

from isoscope.viewer.headless import HeadlessViewer
from isoscope.viewer.state import RecentFiles
from isoscope.volumes import open_volume

SIZE = (480, 360)


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    headless.show(open_volume("sphere", resolution=32), iso=0.0)
    yield headless
    headless.release()


def test_changing_the_iso_through_the_state_re_extracts_once(viewer):
    state = viewer.state
    triangles_before = state.n_triangles
    assert state.update(0.0) is False          # nothing moved: no extraction
    state.set_iso(0.25)
    assert state.update(0.0) is True
    assert state.extractor.level == pytest.approx(0.25)
    assert state.n_triangles > triangles_before
    assert state.update(0.0) is False


def test_iso_is_kept_inside_the_range_and_keys_step_by_fractions(viewer):
    state = viewer.state
    low, high = state.value_range
    state.set_iso(high + 100)
    assert state.iso == high
    state.set_iso(low + 0.5 * (high - low))
    state.nudge_iso(+0.01)
    assert state.iso == pytest.approx(low + 0.51 * (high - low))
    state.nudge_iso(-0.10)
    assert state.iso == pytest.approx(low + 0.41 * (high - low))


def test_animation_sweeps_the_iso_through_the_range(viewer):
    state = viewer.state
    low, high = state.value_range
    state.toggle_animation()
    seen = []
    for _ in range(12):
        state.update(0.5)   # 6 s period: 12 half-second frames are one sweep up and down
        seen.append(state.iso)
    assert low < min(seen) < low + 0.1 * (high - low)
    assert high - 0.1 * (high - low) < max(seen) < high
    state.toggle_animation()
    frozen = state.iso
    state.update(0.5)
    assert state.iso == frozen


def test_panel_draws_over_its_corner_only(viewer):
    without_panel = viewer.render(panel=False)
    with_panel = viewer.render(panel=True)
    changed = np.abs(with_panel.astype(int) - without_panel.astype(int)).max(axis=2) > 0
    rows, cols = np.nonzero(changed)
    # The panel sits at the top left; the scene moves right to make room for it.
    panel_right = int(viewer._panel.covered_width)
    assert 200 < panel_right < SIZE[0]
    assert changed[:100, :panel_right].mean() > 0.2


def find_slider_grab(image):
    """Centre (x, y) of the iso slider's grab: imgui's default SliderGrab colour (0.24, 0.52, 0.88)."""
    rows, cols = np.nonzero((np.abs(image.astype(int) - [61, 133, 224]) <= 3).all(axis=2))
    assert len(rows) > 20, "no slider grab in the image"
    return cols.mean(), rows.mean()


def test_panel_slider_follows_the_iso_value(viewer):
    def slider_grab_column(image):
        return find_slider_grab(image)[0]

    low, high = viewer.state.value_range
    viewer.state.set_iso(low + 0.1 * (high - low))
    left = slider_grab_column(viewer.render(panel=True))
    viewer.state.set_iso(low + 0.9 * (high - low))
    right = slider_grab_column(viewer.render(panel=True))
    assert right - left > 150


def test_dragging_the_panel_slider_with_the_mouse_re_extracts(viewer):
    from imgui_bundle import imgui   # the headless panel gets its mouse from imgui's io, as GLFW feeds it

    low, high = viewer.state.value_range
    viewer.state.set_iso(low + 0.5 * (high - low))
    x, y = find_slider_grab(viewer.render(panel=True))
    triangles_before = viewer.state.n_triangles
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
    assert viewer.state.extractor.level == pytest.approx(viewer.state.iso)
    assert viewer.state.n_triangles != triangles_before


def error_pixels(image, panel_right):
    r, g, b = (image[:, :panel_right, k].astype(int) for k in range(3))
    return int(((r > 200) & (g < 140) & (b < 140)).sum())


def test_bad_file_shows_its_error_in_the_panel_and_keeps_the_volume(viewer, tmp_path):
    state = viewer.state
    volume, extractor, iso = state.volume, state.extractor, state.iso
    clean = viewer.render(panel=True)

    broken = tmp_path / "broken.npy"
    broken.write_bytes(b"this is not a numpy file")
    assert state.open(str(broken)) is False
    assert state.error and "\n" not in state.error and "broken.npy" in state.error
    assert state.volume is volume and state.extractor is extractor and state.iso == iso
    shown = viewer.render(panel=True)
    panel_right = int(viewer._panel.covered_width)
    assert error_pixels(shown, panel_right) > 50 + error_pixels(clean, panel_right)

    assert state.open("sphere") is True   # the next good volume clears the error
    assert state.error is None


def test_opening_a_file_adds_it_to_recent_files(gl_ctx, tmp_path):
    recent_path = tmp_path / "config" / "recent.json"
    viewer = HeadlessViewer((64, 64), ctx=gl_ctx)
    viewer.state.recent = RecentFiles(recent_path)
    try:
        data = np.random.default_rng(1).normal(size=(12, 10, 8)).astype(np.float32)
        path = tmp_path / "noise.npy"
        np.save(path, data)
        assert viewer.state.open(str(path)), viewer.state.error
        assert viewer.state.volume.data.shape == (12, 10, 8)
        assert json.loads(recent_path.read_text()) == [str(path.resolve())]
        assert RecentFiles(recent_path).paths == [str(path.resolve())]
    finally:
        viewer.release()


def test_expression_box_opens_an_implicit_function(viewer):
    assert viewer.state.open("expr:x*x + y*y + z*z - 0.25; res=24"), viewer.state.error
    assert viewer.state.volume.data.shape == (24, 24, 24)
    assert viewer.state.n_triangles > 0


def test_object_side_toggle_reverses_the_normals_and_keeps_the_view(viewer):
    state = viewer.state
    serial, iso = state.volume_serial, state.iso
    assert state.inside_below                              # the built-in sphere is a signed distance
    _, _, outward, _ = state.extractor.read_mesh()
    assert state.set_inside_below(False)
    assert not state.inside_below and state.volume.gradient_direction == "descent"
    assert (state.volume_serial, state.iso) == (serial, iso)  # no refit, same level
    _, _, inward, _ = state.extractor.read_mesh()
    np.testing.assert_allclose(inward, -outward, atol=1e-6)
    assert state.set_inside_below(False) is False          # already so: nothing re-extracted


def test_a_volume_read_in_the_background_reports_progress_then_shows(viewer, tmp_path):
    """Files open on a worker thread: the panel's bar follows the loader; the upload happens in update()."""
    path = tmp_path / "ramp.npy"
    np.save(path, np.broadcast_to(np.arange(192, dtype=np.float32), (256, 256, 192)))  # 48 MiB: read in slabs
    state = viewer.state
    state.open_in_background(str(path))
    pending = state.loading
    assert pending.done(wait_s=60)
    assert pending.message != f"opening {path}" and 0 < pending.fraction <= 1  # the loader reported
    assert state.volume.name != "ramp"                  # not shown until the main thread takes it
    viewer.render()                                      # a frame: update() uploads and extracts it
    assert state.loading is None and state.error is None
    assert state.volume.data.shape == (256, 256, 192) and state.n_triangles > 0
    assert str(path.resolve()) in state.recent.paths


def test_a_bad_file_read_in_the_background_keeps_the_volume(viewer, tmp_path):
    state = viewer.state
    before = state.volume
    bad = tmp_path / "broken.npy"
    bad.write_bytes(b"\x93NUMPY garbage")
    state.open_in_background(str(bad))
    assert state.loading.done(wait_s=60)
    viewer.render()
    assert state.volume is before and state.extractor is not None
    assert state.error and "broken.npy" in state.error and "\n" not in state.error


def test_progress_bar_is_drawn_while_loading(viewer, tmp_path):
    """The panel draws a bar while a load is pending: pixels in the panel differ from a frame without."""
    state = viewer.state
    idle = viewer.render(panel=True)

    class Stalled:  # a load that has not finished: what the panel sees mid-read
        fraction, message = 0.5, "reading ramp"

        def done(self, wait_s=0.0):
            return False

    state.loading = Stalled()
    loading = viewer.render(panel=True)
    state.loading = None
    assert np.abs(loading.astype(int) - idle.astype(int)).max(axis=2)[:, :300].sum() > 0
