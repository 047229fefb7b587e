"""Save rendered pixels as PNG files, and pick unclobbered names for key `s`."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from PIL import Image

from ...io.atomic import write_atomically


def save_png(pixels: np.ndarray, path) -> Path:
    """Write an (height, width, 3 or 4) uint8 array, top row first, to `path` as an RGB or RGBA PNG.

    Written to a temporary name beside it and renamed over it once complete, so a failure never
    leaves half an image or harms an existing one."""
    path = Path(path)
    if path.parent != Path(""):
        path.parent.mkdir(parents=True, exist_ok=True)
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    image = Image.fromarray(pixels, "RGBA" if pixels.shape[2] == 4 else "RGB")
    return write_atomically(path, lambda out: image.save(out, format="PNG"))


def next_screenshot_path(directory, stem: str = "isoscope") -> Path:
    """`directory/isoscope-YYYYmmdd-HHMMSS.png`, with -2, -3 ... when that name is taken."""
    directory = Path(directory)
    base = f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}"
    candidate = directory / f"{base}.png"
    counter = 2
    while candidate.exists():
        candidate = directory / f"{base}-{counter}.png"
        counter += 1
    return candidate
