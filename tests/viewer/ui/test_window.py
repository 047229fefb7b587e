"""Smoke test of the real window: GLFW + GLX under Xvfb, real X key events, a screenshot from key `s`.

Keys go through the X server (see support/x_window.py).  The window runs in a fresh (spawned)
process, as `isoscope` does: a GLX context cannot be made current in a process whose
thread already has the tests' EGL one.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from support.x_window import MAX_FRAMES_PER_STEP, frames_until, press_key, run_spawned

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")

REPO = Path(__file__).resolve().parents[3]


def test_window_draws_takes_keys_and_saves_a_screenshot(x_display, tmp_path):
    run_spawned(drive_window, x_display, tmp_path)
    assert len(list(tmp_path.glob("isoscope-*.png"))) == 2


def drive_window(x_display, tmp_path):
    """The test body, run in the spawned process; any failed assert gives a non-zero exit code."""
    os.environ["DISPLAY"] = x_display
    import glfw

    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(640, 400),
                          screenshot_dir=tmp_path, recent=RecentFiles(None))
    try:
        state = window.state
        for _ in range(3):
            assert window.draw_frame()
        assert state.error is None, state.error
        assert window.scene.stats.n_triangles > 0

        press_key(window, "w")
        assert frames_until(window, lambda: state.style.wireframe)
        low, high = state.value_range
        iso = state.iso
        press_key(window, "equal", shift=True)   # '+': up 10% of the range
        assert frames_until(window, lambda: state.iso == pytest.approx(iso + 0.1 * (high - low)))
        assert window.scene.extractor.level == pytest.approx(state.iso)

        press_key(window, "s")
        assert frames_until(window, lambda: window.last_screenshot is not None)
        shot = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(int)
        assert shot.shape == (400, 640, 3)
        assert str(window.last_screenshot) in state.message
        background = np.round(np.array(state.style.background) * 255)
        assert (shot[-5:, -5:] == background).all()                      # scene background at a corner
        assert np.abs(shot[200, 420] - background).max() > 30           # the surface beside the panel
        assert np.abs(shot[60:200, 20:300] - background).max(axis=2).mean() > 0.3   # the panel

        # Resizing: the next frame and screenshot use the new framebuffer size.
        first_shot = window.last_screenshot
        glfw.set_window_size(window.window, 500, 320)
        assert frames_until(window, lambda: glfw.get_framebuffer_size(window.window) == (500, 320))
        press_key(window, "s")
        assert frames_until(window, lambda: window.last_screenshot != first_shot)
        resized = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(int)
        assert resized.shape == (320, 500, 3)
        assert np.abs(resized[160, 380] - background).max() > 30         # still centred beside the panel

        press_key(window, "Escape")
        assert any(not window.draw_frame() for _ in range(MAX_FRAMES_PER_STEP))
    finally:
        window.close()


def test_isoscope_command_opens_the_window_on_an_expression(x_display):
    # The CLI path end to end; an expr: volume once broke it (an EGL context made before GLX's).
    env = dict(os.environ, DISPLAY=x_display)
    result = subprocess.run([sys.executable, "-m", "isoscope", "expr:x^2 + y^2 - 0.3; res=24", "--frames", "3"],
                            capture_output=True, text=True, env=env, cwd=REPO, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""


def test_the_window_draws_rays_with_the_surfaces_into_its_own_framebuffer(x_display):
    run_spawned(rays_with_surfaces, x_display)


def rays_with_surfaces(x_display):
    """The window's framebuffer is none of ours: the opaque scene drawn once for the rays is copied into it by
    a full-screen pass (gfx/opaque_pass.py), not a blit.  Its picture is the render's (a blit into a
    multisampled target) but for the antialiased edges, the surface changes MIP's picture where it ends
    the rays, at rest and while the view moves, and GL reports no error."""
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.gfx.renderer import read_rgb
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(480, 320), recent=RecentFiles(None))
    try:
        state, ctx = window.state, window.ctx

        def scene(moving: bool = False) -> np.ndarray:
            assert window.draw_frame()
            size = ctx.screen.size
            ctx.screen.use()
            window.app.draw((0, 0, *size), moving=moving)   # the scene alone, no panel over it
            error = ctx.error   # before the read: reading the window's framebuffer sets one on Mesa
            assert error == "GL_NO_ERROR", error
            pixels = read_rgb(ctx.screen, size).astype(int)
            assert ctx.error is not None   # the read's, taken: not the next draw's
            return pixels

        for _ in range(3):
            assert window.draw_frame()
        assert ctx.error == "GL_NO_ERROR"
        state.set_raycast("mip")
        state.slices.show(2, True, 16)
        alone = scene()
        state.set_with_surfaces(True)
        both, moving = scene(), scene(moving=True)
        render = window.app.offscreen(ctx.screen.size).astype(int)
        assert (np.abs(both - render).max(axis=2) > 8).mean() < 0.03
        assert (np.abs(both - alone).max(axis=2) > 30).sum() > 2000
        assert (np.abs(moving - alone).max(axis=2) > 30).sum() > 2000
    finally:
        window.close()
