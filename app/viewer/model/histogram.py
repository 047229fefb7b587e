"""The volume's value histogram under the iso slider: where the data's values lie, to pick a level by.

Counts are shown on a log scale (log1p), as medical viewers do: a scan's background
bin is orders of magnitude taller than the tissue's.  Big volumes are sampled on a
regular sub-grid, which keeps the picture and costs a bounded time.
"""
from __future__ import annotations

import numpy as np

BINS = 128
MAX_SAMPLES = 1 << 24  # above this, every step-th sample along each axis


def value_histogram(data: np.ndarray, value_range: tuple[float, float], bins: int = BINS) -> np.ndarray:
    """log1p of the counts of `data` in `bins` equal bins over `value_range`, as float32."""
    step = 1
    while data.size > MAX_SAMPLES * step**3:
        step += 1
    sample = data[::step, ::step, ::step]
    low, high = value_range
    if high <= low:
        counts = np.zeros(bins)
        counts[0] = sample.size
    else:
        counts, _ = np.histogram(sample, bins=bins, range=(low, high))
    return np.log1p(counts).astype(np.float32)


def level_at(fraction: float, value_range: tuple[float, float]) -> float:
    """The level at `fraction` (0 left, 1 right) of the histogram's width."""
    low, high = value_range
    return low + min(max(float(fraction), 0.0), 1.0) * (high - low)


def fraction_of(level: float, value_range: tuple[float, float]) -> float:
    """Where `level` sits across the histogram's width (0 .. 1)."""
    low, high = value_range
    return 0.0 if high <= low else min(max((level - low) / (high - low), 0.0), 1.0)
