"""DVR's transfer function edited: the model moves a point only where a drag may put it (in order, in the
value range, opacity 0..1), a move changes the ray-cast picture, and a drag over the panel's histogram
moves the point under the mouse (imgui fed as its GLFW backend feeds it)."""
from __future__ import annotations

import numpy as np
import pytest

import isoscope
from isoscope.viewer.model.raycast import moved_point, preset_of
from isoscope.viewer.model.state import ViewerState
from isoscope.viewer.model.style import SurfaceStyle
from isoscope.volumes.inputs import as_volume

BACKGROUND = np.round(255 * np.array(SurfaceStyle().background))
POINTS = ((0.0, 0.0), (0.5, 0.0), (0.9, 1.0), (1.0, 1.0))


def nested() -> np.ndarray:
    """A dim ball (0.4) with a bright core (1.0) inside it, as test_raycast's."""
    axis = np.linspace(-1, 1, 40)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    outer = np.where(np.sqrt(x * x + y * y + z * z) < 0.8, 0.4, 0.0)
    inner = np.where(np.sqrt((x - 0.2) ** 2 + y * y + z * z) < 0.25, 0.6, 0.0)
    return (outer + inner).astype(np.float32)


def test_a_moved_point_stays_between_its_neighbours_and_in_range():
    assert moved_point(POINTS, 1, 0.3, 0.7, (0.0, 1.0))[1] == (0.3, 0.7)
    assert moved_point(POINTS, 1, 0.95, 2.0, (0.0, 1.0))[1] == pytest.approx((0.9 - 1e-4, 1.0))
    assert moved_point(POINTS, 1, -5.0, -1.0, (0.0, 1.0))[1] == pytest.approx((1e-4, 0.0))
    assert moved_point(POINTS, 3, 7.0, 0.5, (0.0, 1.0))[3] == (1.0, 0.5)     # the last: up to the range's end
    assert moved_point(POINTS, 0, -1.0, 0.2, (0.0, 1.0))[0] == (0.0, 0.2)
    assert moved_point(POINTS, 2, 0.8, 0.4, (0.0, 1.0))[::3] == POINTS[::3]   # the others as they were
    with pytest.raises(isoscope.IsoscopeError, match="transfer point 4 is not one of the 4 points"):
        moved_point(POINTS, 4, 0.5, 0.5, (0.0, 1.0))


def test_moving_a_point_needs_a_transfer_function_and_names_a_preset():
    state = ViewerState()
    state.show(as_volume(nested()))
    with pytest.raises(isoscope.IsoscopeError, match="choose a transfer function"):
        state.move_transfer_point(0, 0.5, 0.5)
    state.set_transfer("mri")
    assert preset_of(state.transfer, state.value_range) == "mri"
    state.move_transfer_point(1, 0.35, 0.5)
    assert preset_of(state.transfer, state.value_range) is None and state.transfer[1] == (0.35, 0.5)


def drawn(image) -> int:
    return int(np.count_nonzero(np.abs(image.astype(int) - BACKGROUND).max(axis=2) > 10))


@pytest.mark.gl
def test_moving_a_point_on_the_model_changes_the_picture(gl_ctx):
    """Only the core opaque: the dim ball is not drawn; its value's point raised to opacity 1: it is."""
    from isoscope.viewer.ui.headless import HeadlessViewer
    viewer = HeadlessViewer((200, 150), ctx=gl_ctx)
    try:
        viewer.show(as_volume(nested()), 0.2)
        viewer.state.set_raycast("dvr")
        viewer.state.set_transfer("0:0,0.5:0,0.9:1,1:1")
        core = viewer.picture()
        viewer.state.move_transfer_point(1, 0.4, 1.0)
        both = viewer.picture()
        assert drawn(both) > drawn(core) + 1000, (drawn(core), drawn(both))   # the dim ball's rim
    finally:
        viewer.release()


@pytest.mark.gl
def test_dragging_a_point_over_the_histogram_moves_it(gl_ctx):
    """The panel's editor: press on the second point, drag it up to the top and to the right, release;
    the state's point follows the mouse (kept before its right neighbour) and the picture changes."""
    from imgui_bundle import imgui

    from isoscope.viewer.ui.headless import HeadlessViewer
    viewer = HeadlessViewer((1000, 1400), ctx=gl_ctx)   # tall: the Slices section unscrolled
    try:
        viewer.show(as_volume(nested()), 0.2)
        viewer.state.set_raycast("dvr")
        viewer.state.set_transfer("0:0,0.5:0,0.9:1,1:1")
        for _ in range(2):
            viewer.render(panel=True)
        io = imgui.get_io()   # the panel's imgui context is made on its first frame
        editor = viewer._panel.slices.transfer
        assert editor.box is not None, "no transfer editor in the panel"
        before = viewer.render()
        start = editor.point_at(1, viewer.state)
        io.add_mouse_pos_event(*map(float, start))
        viewer.render(panel=True)
        io.add_mouse_button_event(0, True)
        viewer.render(panel=True)
        (left, top), (right, _) = editor.box
        target = (left + 0.42 * (right - left), top)   # above the plot: opacity 1 (clamped)
        io.add_mouse_pos_event(*map(float, target))
        viewer.render(panel=True)
        io.add_mouse_button_event(0, False)
        viewer.render(panel=True)
        value, opacity = viewer.state.transfer[1]
        assert value == pytest.approx(editor.point_under(*target, viewer.state)[0], abs=0.005)   # a pixel
        assert 0.3 < value < 0.45 and opacity == 1.0
        assert viewer.state.transfer[::2] == ((0.0, 0.0), (0.9, 1.0))
        assert drawn(viewer.render()) > drawn(before) + 1000
    finally:
        viewer.release()


def _drawn_as(viewer, moving: bool) -> np.ndarray:
    """A frame as the window draws it while the view moves (`moving`) or at rest."""
    viewer.target.use()
    viewer.app.draw(viewer.target.viewport, moving=moving)
    return viewer.target.read_rgb()


@pytest.mark.gl
def test_a_frame_after_the_points_move_is_coarse_and_the_next_one_at_rest_is_whole(gl_ctx):
    """As the window draws (previews): a frame after a point moved casts a ray per 2x2 pixels, as while the
    camera moves (the same picture as a moving frame's, pixel for pixel); the frame after it, nothing moved,
    is the whole picture; a move that leaves the points as they were (a drag held still) moves nothing.  A
    render (no previews) is whole after a move."""
    from isoscope.viewer.ui.headless import HeadlessViewer
    for previews in (True, False):
        viewer = HeadlessViewer((200, 150), ctx=gl_ctx, previews=previews)
        try:
            viewer.show(as_volume(nested()), 0.2)
            viewer.state.set_raycast("dvr")
            viewer.state.set_transfer("0:0,0.5:0,0.9:1,1:1")
            viewer.render()

            viewer.state.move_transfer_point(1, 0.4, 1.0)
            after_move = viewer.render()
            at_rest = viewer.render()
            viewer.state.move_transfer_point(1, 0.4, 1.0)   # where it is
            held = viewer.render()
            coarse, whole = (_drawn_as(viewer, moving) for moving in (True, False))
            assert (np.abs(coarse.astype(int) - whole).max(axis=2) > 4).sum() > 100   # the two differ
            assert np.array_equal(after_move, coarse if previews else whole), previews
            assert np.array_equal(at_rest, whole) and np.array_equal(held, whole)
        finally:
            viewer.release()
