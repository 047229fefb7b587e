"""The OpenGL context the GPU code runs in.

The viewer makes a window whose context is current; everything else (tests,
`isoscope render`, `isoscope.marching_cubes(backend="gpu")` from a script) gets a
standalone EGL context, which needs no display (Mesa llvmpipe, or the NVIDIA
driver on a GPU machine).

4.3 is asked for first (compute shaders and storage buffers: the GPU extractor).  Where the driver
gives less, a 4.1 core context is taken (what macOS gives, what Mesa's
MESA_GL_VERSION_OVERRIDE=4.1 imitates): it draws (the viewer, `isoscope render`) while meshes are
extracted on the CPU.  Whether compute is there is decided by the context's version, not by an
extension string, so the override imitates a Mac faithfully.  Callers that run compute shaders ask
with the default `require=REQUIRED_GL` and get GLUnavailable on a 4.1 context.
"""
from __future__ import annotations

import ctypes
import importlib.util

import moderngl

from ..errors import IsoscopeError

REQUIRED_GL = 430  # compute shaders and SSBOs
DRAWING_GL = 410   # the least the viewer and `isoscope render` draw with (4.1 core: macOS)

_standalone: moderngl.Context | None = None
_no_standalone: GLUnavailable | None = None  # why no standalone context could be made: not tried again
_one_shot: str | None = None  # one_shot_backend's choice, made once per process


class GLUnavailable(IsoscopeError, RuntimeError):
    """No OpenGL context of the version asked for could be made here."""


def version_text(code: int) -> str:
    """430 -> "4.3"."""
    return f"{code // 100}.{code % 100 // 10}"


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "swiftshader", "software")
"""GL_RENDERER words of renderers that draw on the CPU (buffers in CPU memory, every triangle costly)."""


def is_software_renderer(ctx: moderngl.Context) -> bool:
    renderer = ctx.info.get("GL_RENDERER", "").lower()
    return any(name in renderer for name in SOFTWARE_RENDERERS)


def has_compute(ctx: moderngl.Context) -> bool:
    """Compute shaders and storage buffers (the GPU extractor): by the context's version, >= 4.3."""
    return ctx.version_code >= REQUIRED_GL


def _check_version(ctx: moderngl.Context, require: int) -> moderngl.Context:
    if ctx.version_code < require:
        raise GLUnavailable(f"the OpenGL context here is {version_text(ctx.version_code)}, and this needs "
                            f"{version_text(require)}" + (" (compute shaders)" if require >= REQUIRED_GL else ""))
    return ctx


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


def current_or_standalone(require: int = REQUIRED_GL) -> moderngl.Context:
    """The context current on this thread (a viewer window's), else a cached standalone EGL one (4.3 where
    the driver has it, else 4.1); GLUnavailable where it is older than `require` (default: compute).

    Whether one is current is asked of libGL directly: moderngl's own detection looks for libGL
    with ctypes.util.find_library, which runs `ldconfig -p` in a subprocess, ~2.3 ms a call, and
    every one-shot `marching_cubes` asked twice.  Where no standalone context can be made, that is
    remembered: the search cost 10-15 ms, and a machine without GL does not grow one."""
    global _standalone, _no_standalone
    if _window_context_current() is not False:
        try:
            ctx = moderngl.create_context(require=DRAWING_GL)
        except Exception:
            ctx = None
        if ctx is not None:
            return _check_version(ctx, require)
    if _no_standalone is not None:
        raise _no_standalone
    if _standalone is None:
        try:
            _standalone = standalone(DRAWING_GL)
        except GLUnavailable as exc:
            _no_standalone = exc
            raise
    return _check_version(_standalone, require)


def standalone(require: int = REQUIRED_GL) -> moderngl.Context:
    """A new headless context (EGL first, then the platform default): 4.3, else (with `require` 410) 4.1 core."""
    errors = []
    for version in (REQUIRED_GL, DRAWING_GL):
        if version < require:
            break
        for kwargs in ({"backend": "egl"}, {}):
            try:
                return moderngl.create_context(standalone=True, require=version, **kwargs)
            except Exception as exc:  # each backend fails in its own way; report them all
                errors.append(f"{version_text(version)} {kwargs.get('backend', 'default')}: {exc}".strip())
    raise GLUnavailable(
        f"no OpenGL {version_text(require)} context: " + "; ".join(errors)
        + " (install Mesa's EGL drivers, e.g. apt-get install libegl1 libgl1-mesa-dri)"
    )


def gl_available() -> bool:
    """A context with compute shaders (4.3) can be had here: what backend="auto" asks."""
    try:
        current_or_standalone()
        return True
    except GLUnavailable:
        return False


def one_shot_backend() -> str:
    """What backend="auto" gives a one-shot extraction (marching_cubes, a chunk, a worker's box, a label
    map): the GPU where an OpenGL 4.3 context can be had on real graphics hardware; the compiled CPU
    extractor where there is none, or where that context is a software renderer such as llvmpipe, which
    runs the compute passes on the same CPU cores and measured 1.2-3x slower one-shot than the compiled
    kernels (benchmarks/results-llvmpipe.md), unless numba is missing.  The same mesh either way.
    Decided once per process (the machine's GL does not change under it): a call costs nothing more."""
    global _one_shot
    if _one_shot is None:
        try:
            _one_shot = one_shot_backend_on(current_or_standalone())
        except GLUnavailable:
            _one_shot = "cpu"
    return _one_shot


def resident_backend(ctx: moderngl.Context | None = None) -> str:
    """What backend="auto" gives a resident `Extractor`: the GPU where `ctx` is given or a window's context is
    current on this thread (its mesh buffers are drawn there), else the one-shot choice: the GPU on graphics
    hardware, the compiled CPU extractor on a software renderer such as llvmpipe (its iso change measured
    x1.2-1.5 Flying Edges against the compute passes' x0.96 on the MNI T1 there) or without GL."""
    if ctx is not None:
        return "gpu"
    if _window_context_current():
        return "gpu" if gl_available() else "cpu"
    return one_shot_backend()


def one_shot_backend_on(ctx: moderngl.Context) -> str:
    """`one_shot_backend` where `ctx` is the context a 4.3 extraction would use."""
    return "cpu" if is_software_renderer(ctx) and importlib.util.find_spec("numba") is not None else "gpu"


def gl_summary(ctx: moderngl.Context) -> str:
    """"OpenGL 4.1, CPU extractor" or "OpenGL 4.3, GPU extractor": what the panel's Stats and --version say."""
    return f"OpenGL {version_text(ctx.version_code)}, {'GPU' if has_compute(ctx) else 'CPU'} extractor"


def describe() -> str:
    """What `isoscope --version` says of GL here: the context to be had, which extractor the viewer uses,
    and what backend="auto" gives one-shot calls (marching_cubes, export)."""
    one_shot = {"cpu": "the compiled CPU extractor", "gpu": "the GPU"}[one_shot_backend()]
    one_shot = f"one-shot calls (marching_cubes, isosurface, export; backend='auto'): {one_shot}"
    try:
        ctx = current_or_standalone(DRAWING_GL)
    except GLUnavailable as exc:
        return (f"no OpenGL here ({str(exc).split(': ', 1)[-1][:120]}): CPU extractor; `isoscope export` and the "
                f"API work, the viewer and `isoscope render` need OpenGL 4.1\n{one_shot}")
    renderer = ctx.info.get("GL_RENDERER", "unknown renderer")
    if has_compute(ctx):
        return (f"OpenGL {version_text(ctx.version_code)} ({renderer}): GPU extractor for the viewer and Extractor "
                f"(compute shaders)\n{one_shot}")
    return (f"OpenGL {version_text(ctx.version_code)} ({renderer}): CPU extractor (no compute shaders below "
            f"{version_text(REQUIRED_GL)}); the viewer and `isoscope render` draw its meshes\n{one_shot}")
