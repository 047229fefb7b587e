"""Helpers for the real window under Xvfb: X key events, the XTest pointer, bounded frame loops, one spawned
process for the windows.

Keys go through the X server (XSendEvent from libX11, which GLFW itself needs),
so they take the same path as a user's: X -> GLFW -> imgui's backend -> our callbacks.
"""
from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import multiprocessing
import time

import numpy as np

MAX_FRAMES_PER_STEP = 20   # X events arrive within a frame or two; bounded, not timed
LEFT, WHEEL_UP = 1, 4   # X button numbers
SETTLE_S = 0.05         # XTest input reaches the client on the server's next dispatch, after the sync reply


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


_window_process = None   # a pool of one spawned process, started by the first run_spawned


def run_spawned(target, *args, fresh: bool = False) -> None:
    """Run a test body in a process of its own (a GLX context needs a thread without the tests' EGL one).
    One spawned process runs the window tests' bodies one after another (each opens and closes its own
    windows, on the same Xvfb display), sparing each the process's start (the interpreter, the imports, GL,
    the shaders); after a body fails, or runs past 300 s, the process is ended and the next body gets a new
    one. A body's exception is raised here, with its traceback from the process. `fresh`: a process of the
    body's own, for a body that changes what the process is (a GL version override before its first context)."""
    global _window_process
    if fresh:
        child = multiprocessing.get_context("spawn").Process(target=target, args=args)
        child.start()
        child.join(timeout=300)
        if child.is_alive():
            child.kill()
        assert child.exitcode == 0, "the window process failed: its traceback is in the captured stderr"
        return
    if _window_process is None:
        _window_process = multiprocessing.get_context("spawn").Pool(1)
        atexit.register(_window_process.terminate)
    try:
        _window_process.apply_async(target, args).get(timeout=300)
    except BaseException:
        _window_process.terminate()
        _window_process = None
        raise


class Pointer:
    """The X pointer, driven through XTest in the window's coordinates (screen units)."""

    def __init__(self, viewer_window):
        import glfw
        self.glfw, self.window = glfw, viewer_window.window
        self.display = glfw.get_x11_display()
        self.xtst = ctypes.CDLL(ctypes.util.find_library("Xtst"))
        self.xtst.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                                   ctypes.c_ulong]
        self.xtst.XTestFakeButtonEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
        self.xlib = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
        self.xlib.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]

    def send(self, *events) -> None:
        """('move', x, y), ('press', button), ('release', button), ...: all queued for the next frame."""
        left, top = self.glfw.get_window_pos(self.window)
        for kind, *args in events:
            if kind == "move":
                self.xtst.XTestFakeMotionEvent(self.display, -1, round(left + args[0]), round(top + args[1]), 0)
            else:
                self.xtst.XTestFakeButtonEvent(self.display, args[0], kind == "press", 0)
        self.xlib.XSync(self.display, 0)
        time.sleep(SETTLE_S)
        self.xlib.XSync(self.display, 0)

    def drag(self, viewer_window, start, end, steps: int = 4) -> None:
        """Press at `start` in the same frame as the pointer arrives there, move to `end` a frame per step, release."""
        self.send(("move", *start), ("press", LEFT))
        viewer_window.draw_frame()
        for t in np.linspace(0, 1, steps + 1)[1:]:
            self.send(("move", *(np.add(start, t * np.subtract(end, start)))))
            viewer_window.draw_frame()
        self.send(("release", LEFT))
        viewer_window.draw_frame()

    def hover(self, viewer_window, point) -> None:
        """Rest the pointer at `point` for a couple of frames, so imgui knows where it is."""
        self.send(("move", *point))
        for _ in range(2):
            viewer_window.draw_frame()


def camera_pose(camera):
    """The camera's pose as one tuple, to compare before and after a press."""
    return (camera.azimuth, camera.elevation, camera.distance, *camera.target)
