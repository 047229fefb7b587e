"""Caps that close a surface where it leaves the volume, for the viewer's "closed at the border".

`export --closed` extracts the whole volume padded with one sample on the outside of any level
(core/closing.py).  The viewer keeps its surface as it is and draws only what that padding adds: the
triangles of the padded volume's cells that touch the padding.  Those cells are the six slabs two
samples thick around the volume, so the caps cost O(n^2) samples, not a second extraction of the
volume, and a drag can remake them every frame.  The slabs split the padding's cells without overlap
(the slab of axis a takes the cells at a's ends, and of the axes before a only the inner cells), so
no cap triangle comes twice.  The cap's rim is the surface's boundary on the volume's faces: the same
crossings of the same edges, so the two meet with no gap.

Saving a closed surface (Save mesh, measure) extracts the padded volume whole, as export does
(`closed_mesh`): its vertices are shared, so the file has no open edge.
"""
from __future__ import annotations

import numpy as np

EMPTY = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64), np.zeros((0, 3), np.float32),
         np.zeros(0, np.float32))


def far_value(value_range, descent: bool) -> np.float32:
    """The value of the padding around the volume: further outside the object than any sample (below the range for
    `descent`, above it for ascent), so every level crosses between the volume and it."""
    from ...core.closing import FAR
    lo, hi = (float(v) for v in value_range)
    far = FAR * (hi - lo + 1.0)
    return np.float32(lo - far if descent else hi + far)


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


def extractor(cells: str, topology: str = "montani"):
    """The extraction isoscope draws, exports and measures: outward-wound cubes (the public `marching_cubes`
    is scikit-image's drop-in, wound the other way) of the `topology` asked for, or marching tetrahedra."""
    from functools import partial

    from ...one_shot import cubes, tetrahedra
    return tetrahedra if cells == "tetrahedra" else partial(cubes, topology=topology)


def caps(data, level: float, spacing=(1.0, 1.0, 1.0), gradient_direction: str = "descent", value_range=None,
         cells: str = "cubes"):
    """(verts, faces, normals, values) of the caps closing the surface `data == level` at the volume's border,
    in index x spacing coordinates (the extractor's); empty where the surface stays inside."""
    descent = gradient_direction == "descent"
    if value_range is None:
        value_range = (float(np.min(data)), float(np.max(data)))
    far = far_value(value_range, descent)
    spacing = np.asarray(spacing, np.float64)
    extract = extractor(cells)
    parts, count = [], 0
    for ranges in slabs(np.shape(data)):
        samples = slab_samples(data, ranges, far)
        if min(samples.shape) < 2 or _all_outside(samples, level, descent):
            continue
        verts, faces, normals, values = extract(samples, level, spacing=tuple(spacing), backend="cpu",
                                                gradient_direction=gradient_direction)
        if not len(faces):
            continue
        offset = (np.array([lo for lo, _ in ranges], np.float64) - 1.0) * spacing
        parts.append(((verts + offset).astype(np.float32), faces.astype(np.int64) + count, normals, values))
        count += len(verts)
    if not parts:
        return EMPTY
    return tuple(np.concatenate([part[i] for part in parts]) for i in range(4))


def _all_outside(samples, level: float, descent: bool) -> bool:
    """No sample inside the object (above the level for descent): the slab has no cap."""
    return bool(np.all(samples < level)) if descent else bool(np.all(samples > level))


def closed_mesh(volume, level: float, cells: str = "cubes", smooth: int = 0, topology: str = "montani"):
    """(verts, faces, normals, values) of `volume` at `level` extracted whole from the padded volume, as
    `export --closed` does: watertight at the border; index x spacing coordinates."""
    from ...core.closing import padded_for_closing, unpad
    from ...validation import as_level
    level = as_level(level, volume.value_range)
    data = padded_for_closing(volume.checked.data, volume.value_range, volume.gradient_direction == "descent")
    verts, faces, normals, values = extractor(cells, topology)(data, level, spacing=volume.spacing, backend="cpu",
                                            gradient_direction=volume.gradient_direction, smooth=smooth)
    return unpad(verts, volume.spacing), faces, normals, values
