"""Helpers for the real window under Xvfb: X key events, bounded frame loops, one spawned process for the windows.

Keys go through the X server (XSendEvent from libX11, which GLFW itself needs),
so they take the same path as a user's: X -> GLFW -> imgui's backend -> our callbacks.
"""
from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import multiprocessing

MAX_FRAMES_PER_STEP = 20   # X events arrive within a frame or two; bounded, not timed


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
