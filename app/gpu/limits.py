"""What the extractor needs from the GL implementation, worked out and checked before it allocates.

`plan_extractor` sizes every texture and buffer of an extractor for a volume shape and
refuses, with one `GPULimitError` line, a volume that would pass one of the limits, so
a construction that cannot succeed allocates nothing.  `GpuLimits` can be given by hand
(tests lower the storage-block limit to reach the refusals with small volumes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl

from ..core.layout import (
    BRICK_I,
    BRICK_J,
    INDEX_BYTES,
    MAX_WORD_IMAGE_SHIFT,
    MAX_WORDS,
    SAMPLES_PER_TEXEL,
    STORAGE_OFFSET_ALIGNMENT,
    WORD_BITS,
    sign_words,
)
from ..errors import IsoscopeError


class GPULimitError(IsoscopeError, ValueError):
    """The volume or its mesh does not fit this GL implementation's limits."""


@dataclass(frozen=True)
class GpuLimits:
    max_3d_texture_size: int
    max_texture_size: int
    max_storage_block_bytes: int

    @classmethod
    def of(cls, ctx: moderngl.Context) -> GpuLimits:
        return cls(int(ctx.info["GL_MAX_3D_TEXTURE_SIZE"]), int(ctx.info["GL_MAX_TEXTURE_SIZE"]),
                   int(ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]))


@dataclass(frozen=True)
class ExtractorPlan:
    """The sizes of one extractor's GPU objects for a volume of `shape`."""
    shape: tuple[int, int, int]
    limits: GpuLimits
    words_per_row: int
    word_count: int
    bricks: tuple[int, int]  # along axes 0 and 1; a brick is one word deep along axis 2
    brick_count: int
    word_shift: int  # per-word images are 2^word_shift texels wide

    @property
    def dims_text(self) -> str:
        return "x".join(map(str, self.shape))

    @property
    def volume_texels(self) -> tuple[int, int, int]:
        """The volume image's size (x, y, z): axis 2 packed SAMPLES_PER_TEXEL samples per texel."""
        n0, n1, n2 = self.shape
        return -(-n2 // SAMPLES_PER_TEXEL), n1, n0

    @property
    def word_image_size(self) -> tuple[int, int]:
        width = 1 << self.word_shift
        return width, -(-self.word_count // width)

    def storage_elements(self) -> dict[str, int]:
        """The uint/float elements of each work buffer, the set-up's row ranges included."""
        return {"brick vertex offsets": self.brick_count + 1, "brick triangle offsets": self.brick_count + 1,
                "brick ranges": 2 * self.brick_count, "active bricks": 1 + self.brick_count,
                "brick states": self.brick_count,
                "row ranges": 2 * self.word_count}

    def windows(self, count: int, record_bytes: int, *parallel_bytes: int) -> list[tuple[int, int]]:
        """`count` records cut into (first, count) windows that a shader can bind as one storage
        block each: at most the storage-block limit, starting at aligned offsets.  A mesh buffer
        may be larger than one block; the passes write it a window at a time.  `parallel_bytes`:
        the record sizes of smaller buffers bound with the same windows (the vertex jobs beside the
        vertices), whose offsets must be aligned too."""
        records = math.lcm(*(STORAGE_OFFSET_ALIGNMENT // math.gcd(size, STORAGE_OFFSET_ALIGNMENT)
                             for size in (record_bytes, *parallel_bytes)))  # a window's first, in records
        unit = records * record_bytes
        per_window = max(unit, self.limits.max_storage_block_bytes // unit * unit) // record_bytes
        return [(first, min(per_window, count - first)) for first in range(0, count, per_window)] or [(0, 0)]

    def triangle_runs(self, n_triangles: int) -> list[tuple[tuple[int, int], tuple[int, int]]]:
        """The triangle pass's runs: per window of the index buffer, the window and the triangle
        slots [first, end) whose words write their vertex jobs in that run (shaders/triangle_runs.glsl);
        the last run's end is 2^32 - 1, so every word writes its jobs in exactly one run."""
        windows = self.windows(n_triangles, INDEX_BYTES)
        ends = [first for first, _ in windows[1:]] + [0xFFFFFFFF]
        return [(window, (window[0] if i else 0, end)) for i, (window, end) in enumerate(zip(windows, ends))]


def plan_extractor(shape, limits: GpuLimits) -> ExtractorPlan:
    """Every size an extractor for `shape` needs, or a GPULimitError naming the first limit passed."""
    n0, n1, n2 = (int(n) for n in shape)
    words_per_row = -(-n2 // WORD_BITS)
    word_count = sign_words((n0, n1, n2))
    bricks = (-(-n0 // BRICK_I), -(-n1 // BRICK_J))
    # Per-word images have rows of 2^shift texels: at most 4096, and fewer than 1/8 of the
    # words (2^(b-1) < words <= 2^b), so the last row's padding is under 1/8 of the image.
    word_shift = max(0, min(MAX_WORD_IMAGE_SHIFT, (word_count - 1).bit_length() - 4))
    plan = ExtractorPlan((n0, n1, n2), limits, words_per_row, word_count, bricks,
                         bricks[0] * bricks[1] * words_per_row, word_shift)
    dims = plan.dims_text
    fix = "crop or downsample it (e.g. volume[::2, ::2, ::2])"

    if max(n0, n1, plan.volume_texels[0]) > limits.max_3d_texture_size:
        raise GPULimitError(
            f"volume {dims} exceeds this GPU's 3-D texture limit of {limits.max_3d_texture_size} samples "
            f"along axes 0 and 1 ({SAMPLES_PER_TEXEL * limits.max_3d_texture_size} along axis 2); {fix}")
    if word_count > MAX_WORDS:
        raise GPULimitError(f"volume {dims} needs more than 2^25 sign words (about 2^30 samples), the "
                            f"extractor's limit; {fix}")
    width, height = plan.word_image_size
    if height > limits.max_texture_size:
        raise GPULimitError(f"volume {dims} needs a {width}x{height} work image, above this GPU's "
                            f"{limits.max_texture_size}-texel limit; {fix}")
    for name, elements in plan.storage_elements().items():
        if elements * 4 > limits.max_storage_block_bytes:
            raise GPULimitError(
                f"volume {dims} needs a {(elements * 4) >> 20} MiB {name} buffer, above this GPU's "
                f"{limits.max_storage_block_bytes >> 20} MiB storage-block limit; {fix}")
    return plan
