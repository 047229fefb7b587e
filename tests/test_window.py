"""Smoke test of the real window: GLFW + GLX under Xvfb, real X key events, a screenshot from key `s`.

Keys go through the X server (XSendEvent from libX11, which GLFW itself needs),
so they take the same path as a user's: X -> GLFW -> imgui's backend -> our callbacks.
The window runs in a fresh (spawned) process, as `isoscope` does: a GLX context
cannot be made current in a process whose thread already has the tests' EGL one.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import multiprocessing
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")

REPO = Path(__file__).resolve().parent.parent
MAX_FRAMES_PER_STEP = 20   # X events arrive within a frame or two; bounded, not timed


@pytest.fixture(scope="module")
def x_display():
    """A private Xvfb server; -displayfd makes it pick a free display number and say when it is ready."""
    read_end, write_end = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                              pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as ready:
        number = ready.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=30)


class XKeyEvent(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("serial", ctypes.c_ulong), ("send_event", ctypes.c_int),
                ("display", ctypes.c_void_p), ("window", ctypes.c_ulong), ("root", ctypes.c_ulong),
                ("subwindow", ctypes.c_ulong), ("time", ctypes.c_ulong), ("x", ctypes.c_int), ("y", ctypes.c_int),
                ("x_root", ctypes.c_int), ("y_root", ctypes.c_int), ("state", ctypes.c_uint),
                ("keycode", ctypes.c_uint), ("same_screen", ctypes.c_int)]


class XEvent(ctypes.Union):
    _fields_ = [("xkey", XKeyEvent), ("pad", ctypes.c_long * 24)]


def press_key(viewer_window, keysym: str, shift: bool = False) -> None:
    """Press and release a key in the window, through the X server."""
    import glfw
    xlib = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    xlib.XStringToKeysym.restype = ctypes.c_ulong
    xlib.XStringToKeysym.argtypes = [ctypes.c_char_p]
    xlib.XKeysymToKeycode.restype = ctypes.c_ubyte
    xlib.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
    xlib.XSendEvent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long, ctypes.POINTER(XEvent)]
    xlib.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
    display, window = glfw.get_x11_display(), glfw.get_x11_window(viewer_window.window)
    keycode = xlib.XKeysymToKeycode(display, xlib.XStringToKeysym(keysym.encode()))
    assert keycode, keysym
    for event_type, mask in ((2, 1 << 0), (3, 1 << 1)):   # KeyPress/KeyPressMask, KeyRelease/KeyReleaseMask
        event = XEvent()
        key = event.xkey
        key.type, key.send_event, key.display, key.window = event_type, 1, display, window
        key.keycode, key.state, key.same_screen = keycode, 1 if shift else 0, 1   # state bit 0: Shift
        xlib.XSendEvent(display, window, 1, mask, ctypes.byref(event))
    xlib.XSync(display, 0)   # the server has queued the events back to GLFW's connection


def frames_until(viewer_window, condition) -> bool:
    for _ in range(MAX_FRAMES_PER_STEP):
        if not viewer_window.draw_frame():
            return condition()
        if condition():
            return True
    return False


def run_spawned(target, *args) -> None:
    """Run a test body in a fresh process (a GLX context needs a thread without the tests' EGL one)."""
    child = multiprocessing.get_context("spawn").Process(target=target, args=args)
    child.start()
    child.join(timeout=300)
    if child.is_alive():
        child.kill()
    assert child.exitcode == 0, "the window process failed: its traceback is in the captured stderr"


def test_window_draws_takes_keys_and_saves_a_screenshot(x_display, tmp_path):
    run_spawned(drive_window, x_display, tmp_path)
    assert len(list(tmp_path.glob("isoscope-*.png"))) == 2


def drive_window(x_display, tmp_path):
    """The test body, run in the spawned process; any failed assert gives a non-zero exit code."""
    os.environ["DISPLAY"] = x_display
    import glfw
    from isoscope.viewer.recent import RecentFiles
    from isoscope.viewer.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(640, 400),
                          screenshot_dir=tmp_path, recent=RecentFiles(None))
    try:
        state = window.state
        for _ in range(3):
            assert window.draw_frame()
        assert state.error is None, state.error
        assert state.n_triangles > 0

        press_key(window, "w")
        assert frames_until(window, lambda: state.style.wireframe)
        low, high = state.value_range
        iso = state.iso
        press_key(window, "equal", shift=True)   # '+': up 10% of the range
        assert frames_until(window, lambda: state.iso == pytest.approx(iso + 0.1 * (high - low)))
        assert state.extractor.level == pytest.approx(state.iso)

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
