"""The volume's upload: RGBA32F texels of 4 consecutive axis-2 samples, so one image load reads 4."""
from __future__ import annotations

import moderngl
import numpy as np

from .gpu_layout import SAMPLES_PER_TEXEL
from .gpu_limits import ExtractorPlan, GPULimitError

UPLOAD_SLAB_BYTES = 16 << 20
"""A volume that needs padding or a cast to float32 goes up a slab of this many bytes at a time."""


def upload_volume(ctx: moderngl.Context, field: np.ndarray, plan: ExtractorPlan) -> moderngl.Texture3D:
    """`field` (checked, any numeric dtype) as the extractor's volume image; texel (q, j, i) holds
    field[i, j, 4q .. 4q + 3], rows padded with zeros to whole texels."""
    n0, n1, n2 = plan.shape
    quads = plan.volume_texels[0]
    texture = None
    try:
        if n2 % SAMPLES_PER_TEXEL == 0 and field.dtype == np.float32:  # already RGBA texels: no copy
            return ctx.texture3d(plan.volume_texels, 4, field, dtype="f4")
        texture = ctx.texture3d(plan.volume_texels, 4, dtype="f4")
        texel_plane_bytes = n1 * quads * 4 * SAMPLES_PER_TEXEL
        planes = min(n0, max(1, UPLOAD_SLAB_BYTES // texel_plane_bytes))
        buffer = np.zeros((planes, n1, SAMPLES_PER_TEXEL * quads), np.float32)  # one, reused: padding stays 0
        for i0 in range(0, n0, planes):
            slab = buffer[:min(planes, n0 - i0)]
            slab[:, :, :n2] = field[i0:i0 + planes]
            texture.write(slab, viewport=(0, 0, i0, quads, n1, len(slab)))
        return texture
    except moderngl.Error as exc:
        if texture is not None:
            texture.release()
        raise GPULimitError(f"volume {plan.dims_text} ({field.nbytes >> 20} MiB) could not be uploaded "
                            f"to the GPU ({exc}); crop or downsample it") from None
