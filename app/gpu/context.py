"""The OpenGL context the GPU code runs in.

The viewer makes a window whose context is current; everything else (tests,
`isoscope render`, `isoscope.marching_cubes(backend="gpu")` from a script) gets a
standalone EGL context, which needs no display (Mesa llvmpipe, or the NVIDIA
driver on a GPU machine).
"""
from __future__ import annotations

import ctypes

import moderngl

from ..errors import IsoscopeError

REQUIRED_GL = 430  # compute shaders and SSBOs

_standalone: moderngl.Context | None = None


class GLUnavailable(IsoscopeError, RuntimeError):
    """No OpenGL 4.3 context could be made here."""


_glx_current = None  # libGL's glXGetCurrentContext, loaded once; False where it cannot be had


def _window_context_current() -> bool | None:
    """Whether a GLX context (a viewer window's) is current on this thread, by asking libGL directly;
    None where libGL cannot be asked (not Linux/X11)."""
    global _glx_current
    if _glx_current is None:
        try:
            function = ctypes.CDLL("libGL.so.1").glXGetCurrentContext
            function.restype = ctypes.c_void_p
            _glx_current = function
        except (OSError, AttributeError):
            _glx_current = False
    return None if _glx_current is False else bool(_glx_current())


def current_or_standalone() -> moderngl.Context:
    """The context current on this thread (a viewer window's), else a cached standalone EGL one.

    Whether one is current is asked of libGL directly: moderngl's own detection looks for libGL
    with ctypes.util.find_library, which runs `ldconfig -p` in a subprocess, ~2.3 ms a call, and
    every one-shot `marching_cubes` asked twice."""
    global _standalone
    if _window_context_current() is not False:
        try:
            ctx = moderngl.create_context(require=REQUIRED_GL)
            return ctx
        except Exception:
            pass
    if _standalone is None:
        _standalone = standalone()
    return _standalone


def standalone() -> moderngl.Context:
    """A new headless context (EGL first, then the platform default)."""
    errors = []
    for kwargs in ({"backend": "egl"}, {}):
        try:
            return moderngl.create_context(standalone=True, require=REQUIRED_GL, **kwargs)
        except Exception as exc:  # each backend fails in its own way; report them all
            errors.append(f"{kwargs.get('backend', 'default')}: {exc}".strip())
    raise GLUnavailable(
        "no OpenGL 4.3 context: " + "; ".join(errors)
        + " (install Mesa's EGL drivers, e.g. apt-get install libegl1 libgl1-mesa-dri)"
    )


def gl_available() -> bool:
    try:
        current_or_standalone()
        return True
    except GLUnavailable:
        return False
