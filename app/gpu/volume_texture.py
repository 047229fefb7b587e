"""The volume's upload: RGBA texels of 4 consecutive axis-2 samples, so one image load reads 4.

8- and 16-bit integer samples stay integers (layout.VOLUME_TEXEL_FORMATS), in either byte order; anything
else becomes float32.  A C-ordered volume whose rows fill whole texels and whose type needs no conversion
goes up as it is, without a copy; otherwise a slab at a time is padded, converted or put in texel order:
slabs of planes of axis 0, or for a volume whose axis 0 is contiguous in memory (Fortran order, nibabel's)
slabs of whole texels along axis 2, each a contiguous block of its memory.  No copy of the whole volume.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..core.layout import SAMPLES_PER_TEXEL, volume_texel_format
from .limits import ExtractorPlan, GPULimitError

UPLOAD_SLAB_BYTES = 16 << 20
"""A volume that needs padding or conversion goes up a slab of about this many bytes at a time."""


def texel_dtype(field: np.ndarray) -> np.dtype:
    """The numpy type of the samples as the volume image holds them."""
    texture_dtype = volume_texel_format(field.dtype)[0]
    return np.dtype({"u1": np.uint8, "i1": np.int8, "u2": np.uint16, "i2": np.int16}.get(texture_dtype, np.float32))


def upload_volume(ctx: moderngl.Context, field: np.ndarray, plan: ExtractorPlan) -> moderngl.Texture3D:
    """`field` (checked) as the extractor's volume image; texel (q, j, i) holds field[i, j, 4q .. 4q + 3],
    rows padded with zeros to whole texels."""
    texture_dtype = volume_texel_format(field.dtype)[0]
    texture = None
    try:
        if _as_texels(field):  # already RGBA texels: no copy
            return ctx.texture3d(plan.volume_texels, 4, field, dtype=texture_dtype)
        texture = ctx.texture3d(plan.volume_texels, 4, dtype=texture_dtype)
        _write_slabs(texture, field, plan)
        return texture
    except moderngl.Error as exc:
        if texture is not None:
            texture.release()
        raise GPULimitError(f"volume {plan.dims_text} ({field.nbytes >> 20} MiB) could not be uploaded "
                            f"to the GPU ({exc}); crop or downsample it") from None


def write_volume(texture: moderngl.Texture3D, field: np.ndarray, plan: ExtractorPlan) -> None:
    """`field` (checked, of the shape and texel type `texture` was made for by upload_volume) into
    `texture`, in place: no new storage (which llvmpipe zeroes and the OS maps page by page)."""
    if _as_texels(field):
        texture.write(field)
    else:
        _write_slabs(texture, field, plan)


def _as_texels(field: np.ndarray) -> bool:
    """Whether `field`'s bytes are the image's texels as they are (C order, rows of whole texels, no
    conversion)."""
    return field.shape[2] % SAMPLES_PER_TEXEL == 0 and field.dtype == texel_dtype(field) and field.flags.c_contiguous


def _write_slabs(texture: moderngl.Texture3D, field: np.ndarray, plan: ExtractorPlan) -> None:
    """Pad or convert `field` a slab of planes at a time into `texture`."""
    n0, n1, n2 = plan.shape
    quads = plan.volume_texels[0]
    stored = texel_dtype(field)
    if n0 > 1 and abs(field.strides[0]) < abs(field.strides[2]):
        _write_texel_slabs(texture, field, plan, stored)
        return
    texel_plane_bytes = n1 * quads * SAMPLES_PER_TEXEL * stored.itemsize
    planes = min(n0, max(1, UPLOAD_SLAB_BYTES // texel_plane_bytes))
    buffer = np.zeros((planes, n1, SAMPLES_PER_TEXEL * quads), stored)  # one, reused: padding stays 0
    for i0 in range(0, n0, planes):
        slab = buffer[:min(planes, n0 - i0)]
        slab[:, :, :n2] = field[i0:i0 + planes]
        texture.write(slab, viewport=(0, 0, i0, quads, n1, len(slab)))


def _write_texel_slabs(texture: moderngl.Texture3D, field: np.ndarray, plan: ExtractorPlan, stored: np.dtype) -> None:
    """`field`, whose axis 0 varies fastest in memory, a slab of whole texels along axis 2 at a time: each slab
    is a contiguous block of a Fortran-ordered array, put in texel order (C order) in one reused buffer."""
    n0, n1, n2 = plan.shape
    quads = plan.volume_texels[0]
    texel_column_bytes = n0 * n1 * SAMPLES_PER_TEXEL * stored.itemsize
    step = min(quads, max(1, UPLOAD_SLAB_BYTES // texel_column_bytes))
    buffer = np.zeros((n0, n1, SAMPLES_PER_TEXEL * step), stored)   # the last texel's padding stays 0
    for q0 in range(0, quads, step):
        count = min(step, quads - q0)
        k0 = q0 * SAMPLES_PER_TEXEL
        k1 = min(n2, (q0 + count) * SAMPLES_PER_TEXEL)
        slab = buffer[:, :, :count * SAMPLES_PER_TEXEL]
        slab[:, :, :k1 - k0] = field[:, :, k0:k1]
        texture.write(np.ascontiguousarray(slab), viewport=(q0, 0, 0, count, n1, n0))
