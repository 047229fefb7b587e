"""The volume's trilinear interpolant, in the two forms its users need.

`trilinear`: F and its gradient in float32, step for step as the smoothing shaders (shaders/smooth_*.comp),
so that numpy's smoothed mesh is the GPU's.  `trilinear_value`: F alone in float64, clamped to the grid,
for measuring and choosing.  One cannot stand in for the other: their roundings differ, and the sharp
step's choice of planes (isoscope.core.sharp.planes) follows `trilinear_value`'s to the last bit.
"""
from __future__ import annotations

import numpy as np

F32 = np.float32


def trilinear(field: np.ndarray, x: np.ndarray):
    """F and its gradient (index units) at points x (N, 3) inside the grid: the trilinear interpolant, in
    float32 in the smoothing shaders' order of operations (shaders/smooth_*.comp)."""
    top = np.array(field.shape) - 2
    cell = np.clip(np.floor(x).astype(np.int64), 0, top)
    f = (x - cell).astype(F32)
    i, j, k = cell.T
    v = {(a, b, c): field[i + a, j + b, k + c] for a in (0, 1) for b in (0, 1) for c in (0, 1)}
    f0, f1, f2 = f.T

    def lerp(lo, hi, t):
        return lo + t * (hi - lo)
    c00, c01 = lerp(v[0, 0, 0], v[0, 0, 1], f2), lerp(v[0, 1, 0], v[0, 1, 1], f2)
    c10, c11 = lerp(v[1, 0, 0], v[1, 0, 1], f2), lerp(v[1, 1, 0], v[1, 1, 1], f2)
    d0, d1 = lerp(c00, c01, f1), lerp(c10, c11, f1)
    e0 = lerp(v[0, 0, 1] - v[0, 0, 0], v[0, 1, 1] - v[0, 1, 0], f1)
    e1 = lerp(v[1, 0, 1] - v[1, 0, 0], v[1, 1, 1] - v[1, 1, 0], f1)
    grad = np.stack([d1 - d0, lerp(c01 - c00, c11 - c10, f0), lerp(e0, e1, f0)], axis=1)
    return lerp(d0, d1, f0), grad


def trilinear_value(field: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The field's trilinear interpolant at `points` (N, 3) in index coordinates, clamped to the grid, in
    float64: for measuring (decimate.distance_off_level_set) and choosing (the sample planes' line,
    isoscope.core.sharp.planes)."""
    upper = np.array(field.shape) - 1
    points = np.clip(points, 0, upper)
    low = np.minimum(np.floor(points).astype(np.int64), np.maximum(upper - 1, 0))
    t = points - low
    value = np.zeros(len(points))
    for corner in range(8):
        offset = np.array([(corner >> a) & 1 for a in range(3)])
        weight = np.prod(np.where(offset, t, 1 - t), axis=1)
        index = tuple((low + offset).T)
        value += weight * field[index]
    return value
