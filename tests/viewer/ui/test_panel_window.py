"""The panel in the real window under Xvfb (issue 26, points 5 and 6): it follows the window's height,
its folded sections are there again in the next run (panel.json beside recent.json), and a drag orbits
as far across a window whatever its size (a 300x100 drag in a 1280x800 window no longer turns the view
straight down).  Pointer input through XTest (support/x_window.py)."""
from __future__ import annotations

import ctypes.util
import json
import os
import shutil

import pytest
from support.x_window import frames_until, press_key, run_spawned

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None or ctypes.util.find_library("Xtst") is None,
                                reason="Xvfb and libXtst are needed for the window test")


def test_the_panel_follows_the_window_and_remembers_its_sections(x_display, tmp_path):
    run_spawned(follow_and_remember, x_display, tmp_path)
    assert json.loads((tmp_path / "panel.json").read_text()) == {"version": 1, "sections": {"Volume": False}}


def open_window(x_display, tmp_path, size):
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume
    window = ViewerWindow(open_volume("sphere", resolution=32), size=size,
                          recent=RecentFiles(tmp_path / "recent.json"), screenshot_dir=tmp_path)
    for _ in range(3):
        assert window.draw_frame()
    return window


def bottom(window) -> float:
    x, y, width, height = window.panel.box
    return y + height


def follow_and_remember(x_display, tmp_path):
    import glfw
    from support.x_window import Pointer
    window = open_window(x_display, tmp_path, (960, 420))
    try:
        status = window.panel.status_height()
        assert bottom(window) <= 420 - status, "the panel runs past the short window"
        short = window.panel.box[3]
        glfw.set_window_size(window.window, 960, 760)
        assert frames_until(window, lambda: window.panel.box[3] > short + 250), "the panel did not grow"
        assert bottom(window) <= 760 - status
        # A screenshot's message (key s) goes to the status line: the slider stays where it was.
        slider = window.panel.iso_slider_box
        press_key(window, "s")
        assert frames_until(window, lambda: window.last_screenshot is not None and window.panel.status_box)
        assert window.panel.iso_slider_box == slider, "the message moved the iso slider"
        assert window.panel.status_box[1] >= bottom(window)
        iso_top = slider[0][1]
        # Fold the Volume section: its header's click.
        (left, top), (right, low) = window.panel.section_boxes["Volume"]
        pointer = Pointer(window)
        pointer.hover(window, ((left + right) / 2, (top + low) / 2))
        pointer.send(("press", 1))
        window.draw_frame()
        pointer.send(("release", 1))
        assert frames_until(window, lambda: window.panel.iso_slider_box[0][1] < iso_top - 50), "Volume did not fold"
    finally:
        window.close()
    again = open_window(x_display, tmp_path, (960, 760))   # the next run
    try:
        assert again.panel.iso_slider_box[0][1] < iso_top - 50, "the Volume section came back open"
    finally:
        again.close()


def test_a_drag_across_the_same_share_of_any_window_orbits_as_far(x_display, tmp_path):
    run_spawned(drag_in_two_windows, x_display, tmp_path)


def drag_in_two_windows(x_display, tmp_path):
    from support.x_window import Pointer
    turns = []
    # 300x100 px in a 1280x800 window, at three quarters and half its size (the test screen is 1024x768).
    for scale in (0.75, 0.5):
        window = open_window(x_display, tmp_path, (int(1280 * scale), int(800 * scale)))
        try:
            camera = window.camera
            start = (1280 * scale - 300 * scale - 20, 100.0)   # right of the panel
            before = (camera.azimuth, camera.elevation)
            Pointer(window).drag(window, start, (start[0] + 300 * scale, start[1] + 100 * scale))
            turns.append(((before[0] - camera.azimuth) % 360, camera.elevation - before[1]))
        finally:
            window.close()
    (azimuth, elevation), (azimuth_small, elevation_small) = turns
    assert 15 < elevation < 30, f"a 100 px drag up an 800 px window turned {elevation:.1f} degrees"
    assert 60 < azimuth < 75
    assert (azimuth_small, elevation_small) == pytest.approx((azimuth, elevation), abs=2.0)
