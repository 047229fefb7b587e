"""Key `s` with --screenshot-scale N: a PNG of the scene at N times the window's pixels (real window, Xvfb)."""
from __future__ import annotations

import os
import shutil

import numpy as np
import pytest
from PIL import Image
from support.x_window import frames_until, press_key, run_spawned

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")


def test_key_s_saves_the_scene_at_the_screenshot_scale(x_display, tmp_path):
    run_spawned(drive_window, x_display, tmp_path)


def drive_window(x_display, tmp_path):
    """Run in a spawned process (a GLX context cannot share a process with the tests' EGL one)."""
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=24), size=(200, 120), screenshot_dir=tmp_path,
                          recent=RecentFiles(None), screenshot_scale=3)
    try:
        assert window.draw_frame()
        press_key(window, "s")
        assert frames_until(window, lambda: window.last_screenshot is not None)
        assert window.state.error is None, window.state.error
        shot = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(int)
        assert shot.shape == (360, 600, 3)
        background = np.round(np.array(window.state.style.background) * 255)
        assert (shot[:6, :6] == background).all()                    # no panel in the corner: scene only
        assert np.abs(shot[180, 300] - background).max() > 30         # the sphere in the middle
    finally:
        window.close()
