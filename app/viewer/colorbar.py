"""The colour bar of a colour-by (colorby.py) drawn into a headless render's pixels, at the right edge.

The window shows its bar in the panel (imgui); `isoscope render` without the panel gets this
one, so a screenshot of a coloured surface always says what its colours mean.
"""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from .colorby import ColorBy

BAR_WIDTH = 14
MARGIN = 10
TEXT_COLOR = (235, 235, 235)


def draw_colorbar(pixels: np.ndarray, color_by: ColorBy) -> np.ndarray:
    """A copy of (height, width, 3 or 4) uint8 `pixels` with the bar (high value at the top) in the
    BAR_WIDTH columns MARGIN pixels from the right edge, its end values and the scalar's name."""
    height, width, channels = pixels.shape
    image = Image.fromarray(np.ascontiguousarray(pixels), "RGBA" if channels == 4 else "RGB")
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    low, high = color_by.value_range
    labels = [f"{high:.4g}", f"{low:.4g}", color_by.source]
    widths = [draw.textbbox((0, 0), text, font=font)[2] for text in labels]
    top, bottom = MARGIN + 14, height - MARGIN - 14
    left = width - MARGIN - BAR_WIDTH
    if bottom - top < 8 or left - widths[2] - 4 < 0:
        return pixels   # too small an image for a bar
    fractions = np.linspace(1.0, 0.0, bottom - top)
    rows = np.round(color_by.lut[np.minimum((fractions * len(color_by.lut)).astype(int), len(color_by.lut) - 1)]
                    * 255).astype(np.uint8)
    bar = np.repeat(rows[:, None, :], BAR_WIDTH, axis=1)
    if channels == 4:
        bar = np.concatenate([bar, np.full(bar.shape[:2] + (1,), 255, np.uint8)], axis=2)
    image.paste(Image.fromarray(bar, image.mode), (left, top))
    fill = TEXT_COLOR + ((255,) if channels == 4 else ())
    right = width - MARGIN
    draw.text((right - widths[0], top - 13), labels[0], fill=fill, font=font)
    draw.text((right - widths[1], bottom + 2), labels[1], fill=fill, font=font)
    draw.text((left - widths[2] - 4, (top + bottom) // 2 - 6), labels[2], fill=fill, font=font)
    return np.asarray(image)
