"""Save rendered pixels as PNG files, and pick unclobbered names for key `s`."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from PIL import Image


def save_png(rgb: np.ndarray, path) -> Path:
    """Write an (height, width, 3) uint8 array, top row first, to `path`."""
    path = Path(path)
    if path.parent != Path(""):
        path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8), "RGB").save(path)
    return path


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
