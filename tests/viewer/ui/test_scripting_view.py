"""isoscope.view from a script, driven as a person would (issue 25): the window opens on a sphere, `=` is
pressed a few times and Escape closes it, and the level the script gets back is the raised one.  And the
Python doors (view, render, widget, isosurface) refuse a 2-D array, an affine that is not 4x4 and a level
outside the range with one ValueError line, the command line's words, before any window or GL context."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import re
import subprocess
import sys
import time

import numpy as np
import pytest
from support.command import isoscope_here as run_cli

import isoscope

START_LEVEL = 0.1
PRESSES = 4  # `=` raises the selected level by 1% of the value range each time
WINDOW_WAIT_S = 120  # a bound on the wait for the script's window to appear, not a speed requirement

VIEW_SCRIPT = f"""
import numpy as np, isoscope
x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
viewed = isoscope.view(0.6 - np.sqrt(x * x + y * y + z * z), {START_LEVEL}, size=(480, 360))
print(repr(viewed), flush=True)
"""


class XWindowAttributes(ctypes.Structure):
    _fields_ = [("x", ctypes.c_int), ("y", ctypes.c_int), ("width", ctypes.c_int), ("height", ctypes.c_int),
                ("border_width", ctypes.c_int), ("depth", ctypes.c_int), ("visual", ctypes.c_void_p),
                ("root", ctypes.c_ulong), ("class_", ctypes.c_int), ("bit_gravity", ctypes.c_int),
                ("win_gravity", ctypes.c_int), ("backing_store", ctypes.c_int), ("backing_planes", ctypes.c_ulong),
                ("backing_pixel", ctypes.c_ulong), ("save_under", ctypes.c_int), ("colormap", ctypes.c_ulong),
                ("map_installed", ctypes.c_int), ("map_state", ctypes.c_int), ("all_event_masks", ctypes.c_long),
                ("your_event_mask", ctypes.c_long), ("do_not_propagate_mask", ctypes.c_long),
                ("override_redirect", ctypes.c_int), ("screen", ctypes.c_void_p)]


IS_VIEWABLE = 2
X_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)


class Keyboard:
    """Another client of the X server (as a person's keyboard is): finds the window by its title and types
    into it through XTest, with the pointer over it and the input focus on it."""

    def __init__(self, display_name: str):
        self.x = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
        self.xtst = ctypes.CDLL(ctypes.util.find_library("Xtst") or "libXtst.so.6")
        x = self.x
        x.XOpenDisplay.restype = ctypes.c_void_p
        x.XOpenDisplay.argtypes = [ctypes.c_char_p]
        x.XDefaultRootWindow.restype = ctypes.c_ulong
        x.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        x.XQueryTree.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.POINTER(ctypes.c_ulong),
                                 ctypes.POINTER(ctypes.c_ulong), ctypes.POINTER(ctypes.POINTER(ctypes.c_ulong)),
                                 ctypes.POINTER(ctypes.c_uint)]
        x.XFetchName.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.POINTER(ctypes.c_char_p)]
        x.XGetWindowAttributes.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.POINTER(XWindowAttributes)]
        x.XSetInputFocus.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_ulong]
        x.XStringToKeysym.restype = ctypes.c_ulong
        x.XStringToKeysym.argtypes = [ctypes.c_char_p]
        x.XKeysymToKeycode.restype = ctypes.c_ubyte
        x.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
        x.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        x.XFree.argtypes = [ctypes.c_void_p]
        x.XCloseDisplay.argtypes = [ctypes.c_void_p]
        self.xtst.XTestFakeKeyEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
        self.xtst.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                                   ctypes.c_ulong]
        # The script's windows come and go while the tree is read (GLFW's helper window, the window itself as
        # the script ends): a query on one that is gone is a BadWindow error, whose default handler in Xlib
        # ends the process, here the test worker. Such a window is simply not the one looked for.
        x.XSetErrorHandler.restype = ctypes.c_void_p
        x.XSetErrorHandler.argtypes = [ctypes.c_void_p]
        self._ignore_errors = X_ERROR_HANDLER(lambda display, event: 0)
        self._previous_handler = x.XSetErrorHandler(ctypes.cast(self._ignore_errors, ctypes.c_void_p))
        self.display = x.XOpenDisplay(display_name.encode())
        assert self.display, f"cannot open X display {display_name}"

    def viewable_window(self, title_start: str):
        """The top-level window whose title starts with `title_start`, once mapped; else None."""
        root, parent = ctypes.c_ulong(), ctypes.c_ulong()
        children, count = ctypes.POINTER(ctypes.c_ulong)(), ctypes.c_uint()
        if not self.x.XQueryTree(self.display, self.x.XDefaultRootWindow(self.display), ctypes.byref(root),
                                 ctypes.byref(parent), ctypes.byref(children), ctypes.byref(count)):
            return None
        found = None
        for i in range(count.value):
            name = ctypes.c_char_p()
            if self.x.XFetchName(self.display, children[i], ctypes.byref(name)) and name.value:
                attributes = XWindowAttributes()
                self.x.XGetWindowAttributes(self.display, children[i], ctypes.byref(attributes))
                if name.value.decode().startswith(title_start) and attributes.map_state == IS_VIEWABLE:
                    found = (children[i], attributes)
        if children:
            self.x.XFree(children)
        return found

    def type_into(self, window, attributes, *keysyms: str) -> None:
        self.xtst.XTestFakeMotionEvent(self.display, -1, attributes.x + attributes.width // 2,
                                       attributes.y + attributes.height // 2, 0)
        self.x.XSetInputFocus(self.display, window, 1, 0)  # RevertToPointerRoot, CurrentTime
        for keysym in keysyms:
            keycode = self.x.XKeysymToKeycode(self.display, self.x.XStringToKeysym(keysym.encode()))
            assert keycode, keysym
            self.xtst.XTestFakeKeyEvent(self.display, keycode, True, 0)
            self.xtst.XTestFakeKeyEvent(self.display, keycode, False, 0)
            self.x.XSync(self.display, 0)

    def close(self) -> None:
        self.x.XCloseDisplay(self.display)
        self.x.XSetErrorHandler(self._previous_handler)


@pytest.mark.gl
@pytest.mark.skipif(ctypes.util.find_library("Xtst") is None, reason="libXtst is not installed (CI installs it)")
def test_view_returns_the_level_the_user_raised_with_the_keyboard(x_display):
    script = subprocess.Popen([sys.executable, "-c", VIEW_SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=dict(os.environ, DISPLAY=x_display))
    keyboard = Keyboard(x_display)
    try:
        deadline = time.monotonic() + WINDOW_WAIT_S
        found = None
        while found is None and script.poll() is None and time.monotonic() < deadline:
            found = keyboard.viewable_window("isoscope")
            time.sleep(0.2)
        assert found is not None, f"no window appeared: {script.poll()=}"
        keyboard.type_into(*found, *["equal"] * PRESSES, "Escape")
        out, err = script.communicate(timeout=WINDOW_WAIT_S)
    finally:
        keyboard.close()
        if script.poll() is None:
            script.kill()
    assert script.returncode == 0, err
    level = float(re.search(r"Viewed\(level=([-0-9.e]+)", out).group(1))
    levels = re.search(r"levels=\(([^)]*)\)", out).group(1)
    assert level > START_LEVEL, out            # raised, by the keys alone (the script asked for 0.1)
    assert levels.startswith(repr(level)), out  # the one level, the selected one
    assert "shown_shape=(24, 24, 24)" in out, out   # the whole sphere on screen: within the budget, at rest


def sphere():
    x, y, z = np.mgrid[-1:1:16j, -1:1:16j, -1:1:16j]
    return (0.6 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


def doors():
    """Each Python door with its keyword arguments; none opens a window or a GL context before it checks."""
    def widget(volume, level=None, **kw):
        pytest.importorskip("jupyter_rfb")
        return isoscope.widget(volume, level, **kw)
    return {"view": isoscope.view, "render": isoscope.render, "widget": widget, "isosurface": isoscope.isosurface}


def cli_error(*args) -> str:
    """The command line's one error line, without its 'isoscope: error: ' prefix."""
    done = run_cli(*args)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    return lines[0].removeprefix("isoscope: error: ")


@pytest.mark.gl   # held to what `isoscope render` says: it needs a GL context first
@pytest.mark.parametrize("door", ["view", "render", "widget", "isosurface"])
def test_bad_arguments_are_the_commands_one_line_value_error(door, tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)  # a window opened anyway would fail differently
    call = doors()[door]
    flat = np.zeros((4, 4), np.float32)
    np.save(tmp_path / "flat.npy", flat)
    ball = sphere()
    np.save(tmp_path / "ball.npy", ball)

    with pytest.raises(ValueError) as raised:
        call(flat, 0.0)
    said = str(raised.value)
    assert "\n" not in said and said.startswith("ndarray is a 2-D array")
    command = cli_error("render", tmp_path / "flat.npy", "--out", tmp_path / "never.png")
    assert said.removeprefix("ndarray") == command.removeprefix("flat.npy")

    for bad_affine in ({"affine": np.eye(3)}, {"affine": np.eye(4)[:3]}):
        with pytest.raises(ValueError, match=r"^affine must be a finite 4x4 matrix .*not shape \(\d, \d\)$"):
            call(ball, 0.0, **bad_affine)
    with pytest.raises(ValueError, match=r"4x4"):
        call((ball, np.eye(3)), 0.0)

    with pytest.raises(ValueError) as raised:
        call(ball, 5.0)
    said = str(raised.value)
    assert "\n" not in said and "5 is outside" in said and "pick a" in said
    command = cli_error("render", tmp_path / "ball.npy", "--iso", "5", "--out", tmp_path / "never.png")
    assert said.replace("level 5", "--iso 5").replace("ndarray's", "ball.npy's") == command
    assert not (tmp_path / "never.png").exists()
