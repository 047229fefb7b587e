"""Sampling a parsed expression on the GPU: the only module here that touches GL.

The expression becomes the EXPR_BODY macro of shaders/expr_sample.comp (straight-line
statements, see expression.to_glsl); its numbers and the sample coordinates are uploaded
as the same float32 values the numpy back end uses; the grid is filled a slab of axis-0
planes at a time into one reused SSBO, sized under GL_MAX_SHADER_STORAGE_BLOCK_SIZE
(128 MiB on llvmpipe), and read back into the numpy array the Volume will hold.
"""
from __future__ import annotations

import numpy as np

from ..core.layout import StorageBlock, shader_defines
from ..resources import shader_source
from .errors import VolumeError
from .expression import flush_denormals, glsl_compile_ms, to_glsl
from .grid import LOWER_RESOLUTION, Box
from .volume import Progress, refuse_if_too_big, report

LOCAL_SIZE = (8, 8, 1)  # matches expr_sample.comp; 8x8x1 is the fast shape on llvmpipe
_SLAB_BYTES = 64 << 20  # smaller slabs keep the progress bar moving and the read-back cheap
# Formulas estimated to take longer than this to compile are not compiled: the GLSL compiler
# inlines every helper at every use and slows down more than linearly (500 powers: 40 s).
MAX_COMPILE_MS = 3000


class TooCostlyForGPU(VolumeError):
    """The formula would take too long to compile; numpy gives the same samples."""


def _slab_planes(ctx, shape) -> int:
    limit = int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
    plane_bytes = shape[1] * shape[2] * 4
    return max(1, min(shape[0], min(limit, _SLAB_BYTES) // plane_bytes))


def _set_uniform(program, name: str, value) -> None:
    # The compiler drops uniforms an expression does not need (no x: no u_first).
    uniform = program.get(name, None)
    if uniform is not None:
        uniform.value = value


def sample_on_gpu(tree, box: Box, shape: tuple[int, int, int], ctx=None,
                  progress: Progress | None = None) -> np.ndarray:
    """float32 samples of the expression tree at lo + index * step, axis 0 first."""
    if ctx is None:
        from isoscope.gpu.context import current_or_standalone
        ctx = current_or_standalone()
    refuse_if_too_big(shape, 4, "the expression grid", fix=LOWER_RESOLUTION)
    estimate = glsl_compile_ms(tree)
    if estimate > MAX_COMPILE_MS:
        raise TooCostlyForGPU(f"the formula has too many operations to compile for the GPU quickly (about "
                              f"{estimate / 1000:.0f} s, more than {MAX_COMPILE_MS / 1000:.0f} s); "
                              f"use the cpu backend or a shorter formula")
    code = to_glsl(tree)
    out = np.empty(shape, dtype=np.float32)
    inputs = np.concatenate([code.numbers, *(sample_axis(box, axis, n) for axis, n in enumerate(shape))])
    # Not through gpu.programs' cache: each formula compiles once, and the program goes with it.
    program = ctx.compute_shader(shader_source("expr_sample.comp", defines={
        **shader_defines(), "EXPR_BODY": code.body, "EXPR_NUMBERS": f"{len(code.numbers)}u"}))
    planes = _slab_planes(ctx, shape)
    buffer = inputs_buffer = None
    try:
        buffer = ctx.buffer(reserve=planes * shape[1] * shape[2] * 4)
        inputs_buffer = ctx.buffer(inputs.tobytes())
        _set_uniform(program, "u_shape", tuple(int(n) for n in shape))
        buffer.bind_to_storage_buffer(StorageBlock.EXPR_SAMPLES)
        inputs_buffer.bind_to_storage_buffer(StorageBlock.EXPR_INPUTS)
        groups_x = -(-shape[2] // LOCAL_SIZE[0])
        groups_y = -(-shape[1] // LOCAL_SIZE[1])
        for first in range(0, shape[0], planes):
            count = min(planes, shape[0] - first)
            _set_uniform(program, "u_first", first)
            _set_uniform(program, "u_planes", count)
            program.run(groups_x, groups_y, count)
            # The spec requires a barrier before reading SSBO writes back with glGetBufferSubData;
            # llvmpipe forgives its absence, real drivers need not.
            ctx.memory_barrier()
            slab_bytes = count * shape[1] * shape[2] * 4
            out[first:first + count] = np.frombuffer(buffer.read(size=slab_bytes), dtype=np.float32
                                                     ).reshape(count, shape[1], shape[2])
            report(progress, (first + count) / shape[0], "sampling the expression on the GPU")
    finally:
        for resource in (buffer, inputs_buffer, program):
            if resource is not None:
                resource.release()
    return out


def sample_axis(box: Box, axis: int, n: int) -> np.ndarray:
    """The float32 coordinates numpy's `evaluate` gets along one axis (grid.sample_function's)."""
    with np.errstate(all="ignore"):  # the box was checked to fit float32
        return flush_denormals(box.axis(axis, n).astype(np.float32))
