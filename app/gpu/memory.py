"""How much memory the GPU has free, where its driver says: the viewer's default memory budget.

NVIDIA's GL_NVX_gpu_memory_info and AMD's GL_ATI_meminfo report free video memory in KiB; Mesa's llvmpipe,
Intel and Apple report nothing (llvmpipe keeps everything in RAM: core/budget.py then takes half the available
memory).  The figures are read with glGetIntegerv from the GL library that dispatches to the current context
(libglvnd's libOpenGL / libGL, opengl32 on Windows), only where the context lists the extension.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import sys

import moderngl

from ..core.budget import MemoryBudget, default_budget
from .context import is_software_renderer

GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX = 0x9049   # KiB
TEXTURE_FREE_MEMORY_ATI = 0x87FC                          # 4 ints, the first: the free pool's KiB


def _gl_get_integers(name: int, count: int) -> list[int] | None:
    """glGetIntegerv(name) of the current context, or None where the GL library cannot be asked."""
    candidates = ["opengl32"] if sys.platform == "win32" else ["libOpenGL.so.0", "libGL.so.1",
                                                              ctypes.util.find_library("GL")]
    for library in candidates:
        if not library:
            continue
        try:
            function = (ctypes.WinDLL if sys.platform == "win32" else ctypes.CDLL)(library).glGetIntegerv
        except (OSError, AttributeError):
            continue
        values = (ctypes.c_int * count)()
        function(ctypes.c_uint(name), values)
        return list(values)
    return None


def gpu_free_bytes(ctx: moderngl.Context) -> tuple[int | None, str]:
    """(free GPU memory in bytes, the extension that said it), or (None, "") where the driver does not say."""
    extensions = getattr(ctx, "extensions", set())
    try:
        if "GL_NVX_gpu_memory_info" in extensions:
            values = _gl_get_integers(GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, 1)
            if values and values[0] > 0:
                return values[0] * 1024, "GL_NVX_gpu_memory_info"
        if "GL_ATI_meminfo" in extensions:
            values = _gl_get_integers(TEXTURE_FREE_MEMORY_ATI, 4)
            if values and values[0] > 0:
                return values[0] * 1024, "GL_ATI_meminfo"
    except (OSError, ValueError):   # a driver that refuses the query: no figure
        pass
    return None, ""


def give_back_freed_memory() -> None:
    """Return the pages of memory freed since to the system (glibc's malloc_trim; nothing elsewhere).  A brick's
    extraction frees its work arrays among the meshes kept, and glibc keeps those holes resident: 17 MiB of a
    24 MiB budget's process after 64 bricks (benchmarks/results-llvmpipe.md)."""
    global _TRIM
    if _TRIM is None:
        try:
            _TRIM = ctypes.CDLL(None).malloc_trim if sys.platform.startswith("linux") else False
        except (OSError, AttributeError):   # musl and others without it
            _TRIM = False
    if _TRIM:
        _TRIM(0)


_TRIM = None


def default_memory_budget(ctx: moderngl.Context) -> MemoryBudget:
    """The viewer's memory budget in `ctx` when the user gives none (core/budget.default_budget)."""
    if is_software_renderer(ctx):
        return default_budget(None, software=True)
    free, source = gpu_free_bytes(ctx)
    return default_budget(free, software=False, driver=source)
