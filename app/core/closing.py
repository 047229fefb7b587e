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


def far_value(value_range, descent: bool) -> np.float32:
    """The value of the padding around the volume: further outside the object than any sample (below the range for
    `descent`, above it for ascent), so every level crosses between the volume and it."""
    lo, hi = (float(v) for v in value_range)
    far = FAR * (hi - lo + 1.0)
    return np.float32(lo - far if descent else hi + far)


def padded_for_closing(data, value_range: tuple[float, float], descent: bool) -> np.ndarray:
    """`data` (3-D) as float32 inside one sample of padding on every side, on the outside of any level."""
    out = np.full(tuple(n + 2 for n in np.shape(data)), far_value(value_range, descent), np.float32)
    out[1:-1, 1:-1, 1:-1] = data
    return out


def unpad(verts: np.ndarray, spacing) -> np.ndarray:
    """Vertices of the padded volume back in the volume's own index x spacing coordinates."""
    return (verts - np.asarray(spacing, np.float32)).astype(np.float32)


# The viewer's caps (one_shot.border_caps) extract only what the padding adds: the padded volume's cells that touch
# the padding, the six slabs two samples thick around the volume, so the caps cost O(n^2) samples, not a second
# extraction of the volume, and a drag can remake them every frame.  The slabs split the padding's cells without
# overlap (the slab of axis a takes the cells at a's ends, and of the axes before a only the inner cells), so no cap
# triangle comes twice.  The cap's rim is the surface's boundary on the volume's faces: the same crossings of the same
# edges, so the two meet with no gap.

def slabs(shape):
    """The six slabs of padding cells: each one's sample ranges (start, stop) in the padded volume."""
    padded = [n + 2 for n in shape]
    for axis in range(3):
        for side in (0, 1):
            ranges = []
            for b in range(3):
                if b == axis:
                    ranges.append((0, 2) if side == 0 else (padded[b] - 2, padded[b]))
                elif b < axis:
                    ranges.append((1, padded[b] - 1))   # inner cells only: the ends are axis b's slabs
                else:
                    ranges.append((0, padded[b]))
            yield ranges


def slab_samples(data, ranges, far: np.float32) -> np.ndarray:
    """The padded volume's samples in `ranges` (padded index p is data index p - 1; outside it, `far`)."""
    out = np.full([hi - lo for lo, hi in ranges], far, np.float32)
    source, target = [], []
    for (lo, hi), n in zip(ranges, np.shape(data)):
        first, last = max(lo, 1), min(hi, n + 1)   # padded indices that hold data
        if first >= last:
            return out
        source.append(slice(first - 1, last - 1))
        target.append(slice(first - lo, last - lo))
    out[tuple(target)] = np.asarray(data[tuple(source)], np.float32)
    return out


def all_outside(samples, level: float, descent: bool) -> bool:
    """No sample inside the object (above the level for descent): the slab has no cap."""
    return bool(np.all(samples < level)) if descent else bool(np.all(samples > level))
