"""Real pointer input in the real window: who gets a press, imgui's panel or the camera; where the panel may go.

The pointer moves and clicks through the XTest extension (libXtst), so the
X server makes the same events a user's mouse does: X -> GLFW -> imgui's
backend -> our callbacks.  Events sent together before a frame reach GLFW in
that frame's one `poll_events()`: a press that comes with the cursor's arrival,
as a real hand does at llvmpipe's 100+ ms frames.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os

import pytest
from support.x_window import MAX_FRAMES_PER_STEP, WHEEL_UP, Pointer, camera_pose, frames_until, press_key, run_spawned

pytestmark = pytest.mark.skipif(ctypes.util.find_library("Xtst") is None, reason="libXtst is not installed")

def open_window_and_run(x_display, body):
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(640, 400), recent=RecentFiles(None))
    try:
        for _ in range(3):
            assert window.draw_frame()
        assert window.state.error is None, window.state.error
        body(window, Pointer(window))
    finally:
        window.close()


def test_a_press_goes_to_the_panel_or_the_camera_by_where_it_lands(x_display):
    run_spawned(open_window_and_run, x_display, press_routing)


def press_routing(window, pointer):
    state, camera = window.state, window.camera
    (left, top), (right, bottom) = window.panel.iso_slider_box
    slider_y = (top + bottom) / 2
    in_view, also_in_view = (520, 300), (560, 300)   # right of the panel
    assert window.panel.covered_width < in_view[0]

    # From the 3-D view onto the slider, pressing as the cursor arrives: the slider moves, the camera does not.
    pointer.hover(window, in_view)
    pose, iso = camera_pose(camera), state.iso
    pointer.drag(window, (left + 0.25 * (right - left), slider_y), (left + 0.75 * (right - left), slider_y))
    assert state.iso != pytest.approx(iso), "the slider did not take the press"
    assert camera_pose(camera) == pytest.approx(pose), "the camera moved with the slider"

    # From the panel into the 3-D view, pressing as the cursor arrives: the camera orbits, the iso value stays.
    pose, iso = camera_pose(camera), state.iso
    pointer.drag(window, in_view, (in_view[0] + 60, in_view[1] + 20))
    assert camera.azimuth != pytest.approx(pose[0]), "a press in the 3-D view did not orbit"
    assert state.iso == iso

    # The wheel follows the same rule: it zooms over the view, not over the panel.
    pointer.hover(window, (left, slider_y))
    distance = camera.distance
    pointer.send(("move", *also_in_view), ("press", WHEEL_UP), ("release", WHEEL_UP))
    assert frames_until(window, lambda: camera.distance < distance), "the wheel over the 3-D view did not zoom"
    distance = camera.distance
    pointer.send(("move", left, slider_y), ("press", WHEEL_UP), ("release", WHEEL_UP))
    for _ in range(MAX_FRAMES_PER_STEP):
        window.draw_frame()
    assert camera.distance == distance, "the wheel over the panel zoomed"


def test_the_panel_stays_reachable_and_key_r_brings_it_home(x_display):
    run_spawned(open_window_and_run, x_display, panel_placement)


def panel_placement(window, pointer):
    import glfw
    from imgui_bundle import imgui

    from isoscope.viewer.model.camera import HOME_AZIMUTH
    from isoscope.viewer.ui.panel import PANEL_HOME, PANEL_KEEP_VISIBLE, PANEL_TITLE

    def panel_box():
        panel = imgui.internal.find_window_by_name(PANEL_TITLE)
        return panel.pos.x, panel.pos.y, panel.size.x

    def assert_title_bar_inside():
        x, y, width = panel_box()
        window_width, window_height = glfw.get_window_size(window.window)
        assert x + width >= PANEL_KEEP_VISIBLE and x + PANEL_KEEP_VISIBLE <= window_width, (x, width)
        assert 0 <= y and y + imgui.get_frame_height() <= window_height, y

    assert panel_box()[:2] == PANEL_HOME
    title_y = PANEL_HOME[1] + imgui.get_frame_height() / 2
    # Dragged by its title bar far past the bottom-right corner: the pointer leaves the window.
    pointer.drag(window, (150, title_y), (1000, 740))
    assert panel_box()[0] > 300, "the drag did not move the panel"
    assert_title_bar_inside()
    # The window shrinks under it.
    glfw.set_window_size(window.window, 400, 250)
    assert frames_until(window, lambda: glfw.get_window_size(window.window) == (400, 250))
    window.draw_frame()
    assert_title_bar_inside()
    # Dragged past the top-left corner, twice, by the right end of what shows of its title bar.
    for _ in range(2):
        x, y, width = panel_box()
        pointer.drag(window, (min(x + width, 400) - 10, y + imgui.get_frame_height() / 2), (0, 0))
    assert panel_box()[0] < -200, "the drag did not move the panel"
    assert_title_bar_inside()

    # Key r: the panel goes home, and the camera too.
    pointer.drag(window, (380, 200), (390, 230))
    assert window.camera.azimuth != pytest.approx(HOME_AZIMUTH)
    press_key(window, "r")
    assert frames_until(window, lambda: panel_box()[:2] == PANEL_HOME)
    assert window.camera.azimuth == pytest.approx(HOME_AZIMUTH)
