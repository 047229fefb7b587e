"""Closed surfaces for printing and volumes: a surface that leaves the volume is capped at its border.

The volume gets one more sample on every side, far on the outside of any level (below the data's
least value where the object is above the level, `descent`; above its greatest otherwise), and is
extracted as usual: every crossing at the border then has a vertex on the edge into that padding,
next to the border sample (the far value puts it at the edge's margin), so the surface closes there,
wound outwards like the rest, and the mesh is watertight.  Extract at an explicit level (the padding
moves the data's range, and so the default level); then shift the vertices back by one sample
(`unpad`).  3D Slicer and VTK's image-to-surface filters close a segmentation's surface the same way.
"""
from __future__ import annotations

import numpy as np

FAR = 1024.0
"""The padding sits this many value ranges outside the data: the cap's vertices land at the edge margin."""


def padded_for_closing(data, value_range: tuple[float, float], descent: bool) -> np.ndarray:
    """`data` (3-D) as float32 inside one sample of padding on every side, on the outside of any level."""
    lo, hi = (float(v) for v in value_range)
    far = FAR * (hi - lo + 1.0)
    out = np.full(tuple(n + 2 for n in np.shape(data)), np.float32(lo - far if descent else hi + far), np.float32)
    out[1:-1, 1:-1, 1:-1] = data
    return out


def unpad(verts: np.ndarray, spacing) -> np.ndarray:
    """Vertices of the padded volume back in the volume's own index x spacing coordinates."""
    return (verts - np.asarray(spacing, np.float32)).astype(np.float32)
