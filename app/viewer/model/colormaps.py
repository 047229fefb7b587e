"""Colour maps for slices and colour-by, from the `cmap` library (the published tables of
matplotlib, ColorBrewer, cmocean and others; none written by hand)."""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import InputError

COLORMAPS = ("gray", "bone", "viridis", "magma", "inferno", "plasma", "cividis", "turbo", "hot")
"""Offered in the panel; any name the cmap library knows is accepted."""
LUT_SIZE = 256


def colormap_rgba(name: str) -> np.ndarray:
    """(LUT_SIZE, 4) float RGBA in 0..1 of the cmap colour map `name`; a one-line ValueError for an unknown one."""
    from cmap import Colormap  # imported on use: `--help` and the API load no colour tables
    try:
        with warnings.catch_warnings():   # an alias known under two namespaces warns; either is fine
            warnings.simplefilter("ignore")
            return np.asarray(Colormap(name).lut(LUT_SIZE), np.float64)
    except (ValueError, KeyError, TypeError):
        raise InputError(f"unknown colour map {name!r}; try one of {', '.join(COLORMAPS)} "
                         "(any name of the cmap library)") from None


def check_colormap(name: str) -> str:
    """`name` if the cmap library knows it, else the one-line ValueError of `colormap_rgba`."""
    colormap_rgba(name)
    return name
