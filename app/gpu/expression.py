"""A formula's samples computed by a compute shader (shaders/expr_sample.comp): the GL side of the expr:
volumes (volumes/gpu_sampler.py turns the parsed formula into GLSL and checks what it asks for).

The formula is the EXPR_BODY macro (straight-line statements); its numbers and the sample coordinates along
each axis are one input buffer of float32; the grid is filled a slab of axis-0 planes at a time into one
reused storage buffer, sized under GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on llvmpipe), and read back.
"""
from __future__ import annotations

import numpy as np

from ..core.layout import StorageBlock, shader_defines
from ..resources import shader_source

LOCAL_SIZE = (8, 8, 1)  # matches expr_sample.comp; 8x8x1 is the fast shape on llvmpipe
_SLAB_BYTES = 64 << 20  # smaller slabs keep the progress bar moving and the read-back cheap


def _slab_planes(ctx, shape) -> int:
    limit = int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
    plane_bytes = shape[1] * shape[2] * 4
    return max(1, min(shape[0], min(limit, _SLAB_BYTES) // plane_bytes))


def _set_uniform(program, name: str, value) -> None:
    # The compiler drops uniforms an expression does not need (no x: no u_first).
    uniform = program.get(name, None)
    if uniform is not None:
        uniform.value = value


def sample_glsl(ctx, body: str, numbers: np.ndarray, axes, shape: tuple[int, int, int], done=None) -> np.ndarray:
    """float32 samples (axis 0 first) of the formula `body` (GLSL statements over its `numbers` and the
    coordinates `axes`, float32 arrays of each axis's samples) on a grid of `shape`; `done(fraction)` after each
    slab.  Every GL object made here is released here."""
    out = np.empty(shape, dtype=np.float32)
    inputs = np.concatenate([np.asarray(numbers, np.float32), *axes]).astype(np.float32, copy=False)
    # Not through gpu.programs' cache: each formula compiles once, and the program goes with it.
    program = ctx.compute_shader(shader_source("expr_sample.comp", defines={
        **shader_defines(), "EXPR_BODY": body, "EXPR_NUMBERS": f"{len(numbers)}u"}))
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
            if done is not None:
                done((first + count) / shape[0])
    finally:
        for resource in (buffer, inputs_buffer, program):
            if resource is not None:
                resource.release()
    return out
