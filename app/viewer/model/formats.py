"""How the panel writes a level: one format for the iso slider's value, the Surfaces list and the hints,
so they never disagree (130.1 in one place and 130.05 in another)."""
from __future__ import annotations

import math

LEVEL_STEPS = 1000    # a level is written to about a thousandth of the value range
MAX_DECIMALS = 8


def level_decimals(value_range: tuple[float, float]) -> int:
    """Decimals that resolve a thousandth of the range: 1 for 0..255, 3 for -1..1, 0 for -1024..3071."""
    span = float(value_range[1]) - float(value_range[0])
    if not math.isfinite(span) or span <= 0:
        return 3
    return min(max(-math.floor(math.log10(span / LEVEL_STEPS)), 0), MAX_DECIMALS)


def level_format(value_range: tuple[float, float]) -> str:
    """The printf format (imgui's) of a level in this range, e.g. "%.1f"."""
    return f"%.{level_decimals(value_range)}f"


def level_text(value: float, value_range: tuple[float, float]) -> str:
    """A level as the panel writes it."""
    return level_format(value_range) % float(value)
