"""Colour surfaces by a scalar at their vertices, through a colour map of the `cmap` library.

The scalar is one of
- "value": each vertex's own value, carried in its record (the level, so several levels take
  the colours of where they sit in the volume's range);
- "gradient": |gradient| of the volume (world units), where the surface is sharp or soft;
- a second volume of the same shape, e.g. a PET or dose map over an anatomy surface.
The last two live in a float 3-D texture with linear filtering, sampled at each vertex by the
vertex shader: nothing is read back per extraction, so a drag costs no more than without.

This module works the scalar and its range out without GL; gfx/colorby.py uploads them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...volumes import Volume
from .colormaps import LUT_SIZE, colormap_rgba

SOURCES = ("value", "gradient")
DEFAULT_COLORMAP = "viridis"


def colormap_rgb(name: str) -> np.ndarray:
    """(LUT_SIZE, 3) float32 RGB of the `cmap` colour map `name`; a one-line ValueError for an unknown one."""
    return np.ascontiguousarray(colormap_rgba(name)[:, :3], np.float32)


def gradient_magnitude(data: np.ndarray, spacing) -> np.ndarray:
    """|gradient| of `data` by central differences in world units, float32."""
    parts = np.gradient(data.astype(np.float32, copy=False), *spacing)
    return np.sqrt(sum(part * part for part in parts)).astype(np.float32)


@dataclass(eq=False)
class ColorBy:
    """A scalar and a colour map: what colours the surfaces, and what the colour bars show."""
    source: str                      # "value", "|gradient|" or the second volume's name
    colormap: str
    value_range: tuple[float, float]  # the scalar values at the two ends of the map
    lut: np.ndarray                  # (LUT_SIZE, 3) float RGB
    scalar: np.ndarray | None        # the scalar per sample (float32), None for "value" (the vertex's own)
    shape: tuple[int, int, int]
    spacing: tuple[float, float, float]
    spec: str = ""                   # what set_color_by was given: "value", "gradient" or a volume spec
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)   # where the volume on show puts its sample 0 (its origin)

    def color_at(self, scalar: float) -> np.ndarray:
        """The map's RGB at `scalar` (as the shader picks it: nearest of LUT_SIZE entries)."""
        low, high = self.value_range
        t = 0.0 if high <= low else min(max((scalar - low) / (high - low), 0.0), 1.0)
        return self.lut[min(int(t * LUT_SIZE), LUT_SIZE - 1)]


def make_color_by(volume: Volume, source: str, colormap: str, second: Volume | None = None,
                  spec: str = "") -> ColorBy:
    """Colour by `source` ("value", "gradient", or "volume" with `second`, opened from `spec`)
    through `colormap`; a one-line ValueError for an unknown map or a second volume of another shape."""
    lut = colormap_rgb(colormap)
    if source == "value":
        scalar, value_range, name = None, volume.value_range, "value"
    elif source == "gradient":
        scalar = gradient_magnitude(volume.data, volume.spacing)
        value_range, name = (float(scalar.min()), float(scalar.max())), "|gradient|"
    else:
        if second.data.shape != volume.data.shape:
            shape = "x".join(map(str, second.data.shape))
            raise InputError(f"{second.name} is {shape} but {volume.name} is {'x'.join(map(str, volume.data.shape))}; "
                             "colour by a volume of the same shape")
        scalar = np.asarray(second.data, np.float32)
        value_range, name = second.value_range, second.name
    return ColorBy(name, colormap, (float(value_range[0]), float(value_range[1])), lut, scalar,
                   tuple(volume.data.shape), tuple(volume.spacing), spec, tuple(float(o) for o in volume.origin))
