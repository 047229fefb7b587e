"""The colour bar of a colour-by (colorby.py) drawn into a headless render's pixels, at the right edge.

The window shows its bar in the panel (imgui); `isoscope render` without the panel gets this
one, so a screenshot of a coloured surface always says what its colours mean.
"""
from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..model.colorby import ColorBy

BAR_WIDTH = 14
MARGIN = 10
TEXT_COLOR = (235, 235, 235)
LINE = 13              # pixels per line of the default font
MAX_BAR_SHARE = 0.6    # of the image's height
MAX_NAME = 28          # characters of the scalar's name (a file name can be long)
ZERO_SHARE = 1e-6      # a tick within this share of the larger end is rounding: it reads 0
MAX_DIGITS = 7         # float32 holds about 7 significant digits; more are noise


def tick_label(value: float, low: float, high: float) -> str:
    """`value`, one end of the bar running `low`..`high`, as text without float noise: a value within
    rounding (1e-6 of the larger end) of zero is "0", not "1.251e-17"; others get the significant digits
    that tell the two ends apart (3 for 0..1, 6 for 1000..1001) and at least its whole digits (123457),
    at most 7 (float32's)."""
    value, low, high = float(value), float(low), float(high)
    if not math.isfinite(value):
        return str(value)
    scale = max(abs(low), abs(high), abs(value))
    if scale == 0.0 or abs(value) <= ZERO_SHARE * scale:
        return "0"
    span = abs(high - low)
    digits = 3 if span == 0.0 else max(3, math.ceil(math.log10(scale / span)) + 3)
    digits = min(MAX_DIGITS, max(digits, math.floor(math.log10(abs(value))) + 1))  # 123457, not 1.23e+05
    text = f"{value:.{digits}g}"
    return "0" if float(text) == 0.0 else text


def draw_colorbar(pixels: np.ndarray, color_by: ColorBy) -> np.ndarray:
    """A copy of (height, width, 3 or 4) uint8 `pixels` with the bar (high value at the top) in the
    BAR_WIDTH columns MARGIN pixels from the right edge, the scalar's name and the high value above it,
    the low value below."""
    height, width, channels = pixels.shape
    image = Image.fromarray(np.ascontiguousarray(pixels), "RGBA" if channels == 4 else "RGB")
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    low, high = color_by.value_range
    name = color_by.source if len(color_by.source) <= MAX_NAME else color_by.source[:MAX_NAME - 3] + "..."
    labels = [tick_label(high, low, high), tick_label(low, low, high), name]
    widths = [draw.textbbox((0, 0), text, font=font)[2] for text in labels]
    top = MARGIN + 2 * LINE
    bottom = top + min(height - top - MARGIN - LINE, int(MAX_BAR_SHARE * height))
    left = width - MARGIN - BAR_WIDTH
    if bottom - top < 8 or width - MARGIN - max(widths) < 0:
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
    for text, text_width, y in zip(labels, widths, (top - LINE, bottom + 2, top - 2 * LINE)):
        draw.text((right - text_width, y), text, fill=fill, font=font)
    return np.asarray(image)
