"""Volumes the trilinear topology's extractors are checked on (tests/cpu, tests/gpu/test_gpu_trilinear.py)."""
from __future__ import annotations

import numpy as np


def closed_noise(seed: int, n: int = 14):
    rng = np.random.default_rng(seed)
    field = np.full((n, n, n), -1.0, dtype=np.float32)
    field[1:-1, 1:-1, 1:-1] = rng.standard_normal((n - 2,) * 3)
    return field


def gyroid(n=40):
    x, y, z = np.mgrid[0:2 * np.pi:n * 1j, 0:2 * np.pi:n * 1j, 0:2 * np.pi:n * 1j]
    return (np.sin(2 * x) * np.cos(2 * y) + np.sin(2 * y) * np.cos(2 * z) + np.sin(2 * z) * np.cos(2 * x)
            ).astype(np.float32)


def bit_for_bit_cases(seed: int):
    """(name, volume, level, gradient direction) on which every extractor of the topology must give the
    numpy specification's mesh: noise both ways, a Fortran int16 scan, the gyroid, closed noise."""
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((33, 20, 45)).astype(np.float32)
    scan = np.asfortranarray((rng.standard_normal((30, 31, 40)) * 300).astype(np.int16))  # nibabel's layout
    return [("noise", noise, 0.1, "descent"), ("noise ascent", noise, -0.2, "ascent"),
            ("int16 Fortran", scan, 7.5, "descent"), ("gyroid", gyroid(), 0.3, "descent"),
            ("closed", closed_noise(7, 20), 0.0, "descent")]
