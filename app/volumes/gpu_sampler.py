"""Sampling a parsed expression on the GPU: the formula as GLSL (expression.to_glsl), its inputs as the
same float32 values the numpy back end uses, and the checks before it is compiled; the compute shader that
samples it is the GPU layer's (gpu/expression.py).
"""
from __future__ import annotations

import numpy as np

from .errors import VolumeError
from .expression import flush_denormals, glsl_compile_ms, to_glsl
from .grid import LOWER_RESOLUTION, Box
from .volume import Progress, refuse_if_too_big, report

# Formulas estimated to take longer than this to compile are not compiled: the GLSL compiler
# inlines every helper at every use and slows down more than linearly (500 powers: 40 s).
MAX_COMPILE_MS = 3000


class TooCostlyForGPU(VolumeError):
    """The formula would take too long to compile; numpy gives the same samples."""


def sample_on_gpu(tree, box: Box, shape: tuple[int, int, int], ctx=None,
                  progress: Progress | None = None) -> np.ndarray:
    """float32 samples of the expression tree at lo + index * step, axis 0 first."""
    from ..gpu.expression import sample_glsl
    if ctx is None:
        from ..gpu.context import current_or_standalone
        ctx = current_or_standalone()
    refuse_if_too_big(shape, 4, "the expression grid", fix=LOWER_RESOLUTION)
    estimate = glsl_compile_ms(tree)
    if estimate > MAX_COMPILE_MS:
        raise TooCostlyForGPU(f"the formula has too many operations to compile for the GPU quickly (about "
                              f"{estimate / 1000:.0f} s, more than {MAX_COMPILE_MS / 1000:.0f} s); "
                              f"use the cpu backend or a shorter formula")
    code = to_glsl(tree)
    axes = [sample_axis(box, axis, n) for axis, n in enumerate(shape)]
    return sample_glsl(ctx, code.body, code.numbers, axes, shape,
                       done=lambda fraction: report(progress, fraction, "sampling the expression on the GPU"))


def sample_axis(box: Box, axis: int, n: int) -> np.ndarray:
    """The float32 coordinates numpy's `evaluate` gets along one axis (grid.sample_function's)."""
    with np.errstate(all="ignore"):  # the box was checked to fit float32
        return flush_denormals(box.axis(axis, n).astype(np.float32))
