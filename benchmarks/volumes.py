"""The benchmark volumes of FIELD-NOTES.md, generated with numpy (float32, C order).

All three use iso level 0. Their triangle counts at 256^3 match the peers'
figures in FIELD-NOTES (sphere 392 k, gyroid 3.79 M, noise ~7.4 M), and the
sphere gives exactly 97,148 triangles at 128^3 in every peer:

- sphere: signed distance to a sphere of radius 0.8 sampled on linspace(-1, 1, n)
  per axis; negative inside, so gradient_direction="ascent".
- gyroid: sin x cos y + sin y cos z + sin z cos x on linspace(0, 6 * 2 pi, n)
  per axis (6 periods, end points included); "descent".
- noise: gaussian_filter(normal(0, 1), sigma=3) minus its mean, seed 0; "descent".

Each generator builds the field from 1-D axes by broadcasting, so the peak
memory is a small multiple of the volume (a 512^3 float32 volume is 512 MiB).
"""
from __future__ import annotations

import numpy as np


def _axes(n: int, lo: float, hi: float):
    axis = np.linspace(lo, hi, n, dtype=np.float64)
    return axis[:, None, None], axis[None, :, None], axis[None, None, :]


def sphere(n: int) -> np.ndarray:
    x, y, z = (a.astype(np.float32) for a in _axes(n, -1.0, 1.0))
    field = x * x + y * y            # (n, n, 1)
    field = field + z * z            # (n, n, n) float32
    np.sqrt(field, out=field)
    field -= np.float32(0.8)
    return field


def gyroid(n: int) -> np.ndarray:
    x, y, z = _axes(n, 0.0, 6 * 2 * np.pi)
    sx, cx = np.sin(x), np.cos(x)
    sy, cy = np.sin(y), np.cos(y)
    sz, cz = np.sin(z), np.cos(z)
    field = (sx * cy).astype(np.float32)           # (n, n, 1)
    field = field + (sy * cz).astype(np.float32)   # (n, n, n)
    field += (sz * cx).astype(np.float32)
    return field


def noise(n: int, seed: int = 0) -> np.ndarray:
    from scipy.ndimage import gaussian_filter
    rng = np.random.default_rng(seed)
    field = gaussian_filter(rng.standard_normal((n, n, n), dtype=np.float32), sigma=3)
    field -= field.mean(dtype=np.float64).astype(np.float32)
    return field


# name -> (generator, gradient_direction): which side of level 0 is the object.
VOLUMES = {
    "sphere": (sphere, "ascent"),
    "gyroid": (gyroid, "descent"),
    "noise": (noise, "descent"),
}
