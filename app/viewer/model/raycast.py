"""Direct volume rendering's choices (no GL): the modes a ray can gather, and the one line for a bad one.
The GL side is gfx/raycast.py and shaders/raycast.frag."""
from __future__ import annotations

from .errors import ViewerError

RAYCAST_MODES = ("mip", "minip", "mean", "iso", "dvr")
"""mip / minip / mean: the largest, smallest, mean value along each ray, through the colour map over the
window; iso: the level's first hit on the trilinear interpolant, shaded (no mesh made); dvr: emission and
absorption through the colour map and a linear opacity ramp over the window."""


def check_raycast(mode) -> str | None:
    """`mode` (one of RAYCAST_MODES, or None / "off" for the meshes), or a one-line ViewerError."""
    if mode is None or mode == "off":
        return None
    if mode not in RAYCAST_MODES:
        raise ViewerError(f"volume rendering {mode!r} is not one of {', '.join(RAYCAST_MODES)} (or off)")
    return mode
