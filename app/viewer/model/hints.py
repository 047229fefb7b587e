"""What the panel says about a surface that shows nothing: an empty level (where the data's values are
instead), and a surface hidden inside an opaque one.  No GL, no imgui: the panel asks, these answer."""
from __future__ import annotations

import numpy as np

from .formats import level_text

OPAQUE = 0.99              # a surface at least this opaque hides what it encloses
MASS_SHARE = (0.10, 0.90)  # "most between": the values' 10th to 90th percentile
BACKGROUND_SHARE = 0.25    # an end bin holding more than this is background (a scan's air), not the data's mass


def mass_interval(histogram: np.ndarray, value_range: tuple[float, float]) -> tuple[float, float]:
    """Where most of the values lie: the 10th to 90th percentile of the `histogram` (log1p counts in equal
    bins over `value_range`, model/histogram.py), leaving out a background bin at either end."""
    counts = np.expm1(np.asarray(histogram, float))
    low, high = value_range
    edges = np.linspace(low, high, len(counts) + 1)
    total = counts.sum()
    if total <= 0:
        return float(low), float(high)
    for end in (0, len(counts) - 1):
        if counts[end] > BACKGROUND_SHARE * total and counts[end] < total:
            counts[end] = 0.0
    cumulative = np.cumsum(counts) / counts.sum()
    first = int(np.searchsorted(cumulative, MASS_SHARE[0]))
    last = int(np.searchsorted(cumulative, MASS_SHARE[1]))
    return float(edges[first]), float(edges[min(last + 1, len(counts))])


def empty_level_hint(level: float, value_range: tuple[float, float], histogram) -> str:
    """The panel's line for a level whose surface is empty, e.g. "no surface at 254.0: the values lie in
    0.0..254.0, most between 20.0 and 140.0"."""
    low, high = value_range
    text = f"no surface at {level_text(level, value_range)}: the values lie in " \
           f"{level_text(low, value_range)}..{level_text(high, value_range)}"
    if histogram is None:
        return text
    first, last = mass_interval(histogram, value_range)
    return f"{text}, most between {level_text(first, value_range)} and {level_text(last, value_range)}"


def enclosing_levels(levels, inside_is_above: bool, clipped: bool = False, empty=()) -> dict[int, int]:
    """{i: j} for each visible level i that lies inside the visible, opaque level j (so nothing of it shows).
    Level sets of one field nest: with the object above the level (a density), a higher level lies inside
    a lower one; below (a signed distance), a lower one inside a higher.  A clip plane opens them: none;
    the levels in `empty` (no surface) hide nothing."""
    if clipped:
        return {}
    hidden = {}
    for i, inner in enumerate(levels):
        if not inner.visible or inner.opacity <= 0:
            continue
        for j, outer in enumerate(levels):
            if j == i or j in empty or not outer.visible or outer.opacity < OPAQUE:
                continue
            if (inner.value > outer.value) if inside_is_above else (inner.value < outer.value):
                hidden[i] = j
                break
    return hidden
