"""Colour by a scalar on the GPU: the colour map as a 1-D texture and the scalar (|gradient| or a
second volume) as a float 3-D texture with linear filtering, sampled at each vertex by the vertex
shader (what model/colorby.py works out, uploaded).  Nothing is read back per extraction, so a drag
costs no more than without.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..model.colorby import ColorBy
from ..model.colormaps import LUT_SIZE


class GpuColorBy:
    """The textures of one `ColorBy`, and what the renderer reads of it."""

    def __init__(self, ctx: moderngl.Context, color_by: ColorBy):
        self.color_by = color_by
        self.value_range, self.shape, self.spacing = color_by.value_range, color_by.shape, color_by.spacing
        self.origin = color_by.origin
        self.lut_texture = ctx.texture((LUT_SIZE, 1), 3, color_by.lut.tobytes(), dtype="f4")
        self.lut_texture.filter = moderngl.NEAREST, moderngl.NEAREST
        self.lut_texture.repeat_x = self.lut_texture.repeat_y = False
        self.scalar_texture = None
        if color_by.scalar is not None:
            n0, n1, n2 = color_by.scalar.shape   # texel (k, j, i) holds scalar[i, j, k]: axis 2 is the texture's x
            try:
                self.scalar_texture = ctx.texture3d((n2, n1, n0), 1, np.ascontiguousarray(color_by.scalar).tobytes(),
                                                    dtype="f4")
            except BaseException:   # out of GPU memory: the colour map's texture goes with it
                self.lut_texture.release()
                raise
            self.scalar_texture.filter = moderngl.LINEAR, moderngl.LINEAR
            self.scalar_texture.repeat_x = self.scalar_texture.repeat_y = self.scalar_texture.repeat_z = False

    def release(self) -> None:
        """Free the colour map's and the second volume's textures."""
        for texture in (self.lut_texture, self.scalar_texture):
            if texture is not None:
                texture.release()
