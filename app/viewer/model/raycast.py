"""Direct volume rendering's choices (no GL): the modes a ray can gather, and the one line for a bad one.
The GL side is gfx/raycast.py and shaders/raycast.frag."""
from __future__ import annotations

import numpy as np

from ...volumes.volume import shape_text
from .errors import ViewerError

RAYCAST_MODES = ("mip", "minip", "mean", "iso", "dvr")
"""mip / minip / mean: the largest, smallest, mean value along each ray, through the colour map over the
window; iso: the level's first hit on the trilinear interpolant, shaded (no mesh made); dvr: emission and
absorption through the colour map and a linear opacity ramp over the window."""


# A volume's samples as the rays read them: dtype -> (moderngl texture dtype, what one unit of the normalised
# texel is worth), kept exactly in their own type where GL has one; float32 otherwise.
NORMALISED = {np.dtype(np.uint8): ("nu1", 255.0), np.dtype(np.uint16): ("nu2", 65535.0),
              np.dtype(np.int8): ("ni1", 127.0), np.dtype(np.int16): ("ni2", 32767.0)}


def texture_type(dtype) -> tuple[str, float | None]:
    """(moderngl texture dtype, the normalised texel's unit, None for float32) of samples of `dtype`."""
    return NORMALISED.get(np.dtype(dtype), ("f4", None))


def value_map(dtype) -> tuple[float, float]:
    """(scale, offset) taking a texel of samples of `dtype`, as the shader reads it, back to its value."""
    unit = texture_type(dtype)[1]
    return (unit, 0.0) if unit is not None else (1.0, 0.0)


def texel_bytes(dtype) -> int:
    """What one sample of `dtype` takes in the ray caster's textures: its own size where texture_type keeps
    its type, else float32's."""
    return np.dtype(dtype).itemsize if texture_type(dtype)[1] is not None else 4


def texture_samples(array) -> np.ndarray:
    """`array` as the ray caster's texture takes it: C order, in its own type where `texture_type` keeps
    it, else float32."""
    kind, unit = texture_type(np.asarray(array).dtype)
    return np.ascontiguousarray(array if unit is not None else np.asarray(array, dtype=np.float32))


def check_raycast(mode) -> str | None:
    """`mode` (one of RAYCAST_MODES, or None / "off" for the meshes), or a one-line ViewerError."""
    if mode is None or mode == "off":
        return None
    if mode not in RAYCAST_MODES:
        raise ViewerError(f"volume rendering {mode!r} is not one of {', '.join(RAYCAST_MODES)} (or off)")
    return mode


# A transfer function: DVR's opacity (0..1, per unit of extinction) at each value, piecewise linear between
# points of strictly increasing value (0 below the first, the last one's above the last).
# Presets: a CT's bone and soft tissue in Hounsfield units, and an MRI's by fractions of its value range.
PRESETS = {
    "ct-bone": (False, ((150.0, 0.0), (300.0, 0.35), (700.0, 0.8), (1500.0, 1.0))),
    "ct-soft": (False, ((-400.0, 0.0), (-100.0, 0.08), (40.0, 0.3), (150.0, 0.45), (400.0, 0.0))),
    "mri": (True, ((0.12, 0.0), (0.3, 0.15), (0.6, 0.5), (1.0, 0.9))),
}
MAX_TRANSFER_POINTS = 64


def check_transfer_mode(raycast, transfer, flags: bool = False) -> None:
    """A picture drawn once (render, movie, isoscope.render) uses a transfer function only in DVR: one given
    with another mode (or none) would be silently ignored, so it is refused.  `flags`: name the command's
    options, not the keywords."""
    if transfer is None or raycast == "dvr":
        return
    given, wanted = ("--transfer", "--raycast dvr") if flags else ("transfer=", "raycast='dvr'")
    drawn = f"the {raycast} mode" if raycast else "the surfaces"
    raise ViewerError(f"{given} sets DVR's opacity and {drawn} would ignore it: add {wanted} or leave "
                      f"{given.rstrip('=')} out")


def check_transfer(spec, value_range) -> tuple[tuple[float, float], ...] | None:
    """A transfer function from `spec`: None / "off" (the window's linear ramp), a preset's name (PRESETS:
    its points clamped into the volume's range), "V:A,V:A,..." or pairs (value, opacity); the points of a
    given one must lie in the value range, in increasing order of value, opacities 0..1.  ViewerError in
    one line otherwise."""
    if spec is None or spec == "off":
        return None
    low, high = (float(v) for v in value_range)
    if isinstance(spec, str) and spec in PRESETS:
        relative, points = PRESETS[spec]
        points = [(low + v * (high - low), a) if relative else (min(max(v, low), high), a) for v, a in points]
        kept = [points[0]] + [p for before, p in zip(points, points[1:]) if p[0] > before[0]]
        return tuple(kept) if len(kept) >= 2 else ((low, 0.0), (high, max(a for _, a in points)))
    points = _parsed_points(spec)
    for value, opacity in points:
        if not low <= value <= high:
            raise ViewerError(f"transfer point {value:g} lies outside the volume's values {low:g} .. {high:g}; "
                              "give values inside it")
        if not 0.0 <= opacity <= 1.0:
            raise ViewerError(f"transfer opacity {opacity:g} at {value:g} is not 0..1")
    if any(b[0] <= a[0] for a, b in zip(points, points[1:])):
        raise ViewerError(f"transfer points must go up in value ({', '.join(f'{v:g}' for v, _ in points)} do "
                          "not); order them")
    return tuple(points)


def moved_point(points, index: int, value: float, opacity: float, value_range) -> tuple[tuple[float, float], ...]:
    """`points` with point `index` moved to (value, opacity) as a drag puts it: its value kept inside the
    volume's range and strictly between its neighbours' (the order stays), its opacity 0..1."""
    if not 0 <= index < len(points):
        raise ViewerError(f"transfer point {index} is not one of the {len(points)} points (0 .. {len(points) - 1})")
    low, high = (float(v) for v in value_range)
    gap = (high - low) * 1e-4
    below = points[index - 1][0] + gap if index > 0 else low
    above = points[index + 1][0] - gap if index + 1 < len(points) else high
    moved = (min(max(float(value), below), above), min(max(float(opacity), 0.0), 1.0))
    return tuple(moved if i == index else tuple(point) for i, point in enumerate(points))


def preset_of(points, value_range) -> str | None:
    """The preset's name whose points (fitted to `value_range`) `points` are, or None."""
    return next((name for name in PRESETS if points is not None and check_transfer(name, value_range) == points),
                None)


def _parsed_points(spec) -> list[tuple[float, float]]:
    import math
    try:
        if isinstance(spec, str):
            pairs = [part.split(":") for part in spec.replace(" ", "").split(",") if part]
            points = [(float(v), float(a)) for v, a in pairs]
        else:
            points = [(float(v), float(a)) for v, a in spec]
    except (TypeError, ValueError):
        raise ViewerError(f"transfer {str(spec)[:60]!r} is not VALUE:OPACITY,... (e.g. 200:0,500:0.5,1200:1) "
                          f"nor one of {', '.join(PRESETS)}") from None
    if not 2 <= len(points) <= MAX_TRANSFER_POINTS or not all(math.isfinite(v) and math.isfinite(a)
                                                              for v, a in points):
        raise ViewerError(f"a transfer function is 2 to {MAX_TRANSFER_POINTS} finite VALUE:OPACITY points")
    return points


def surfaces_drawn(state) -> bool:
    """Whether the picture draws the surfaces (not the ray-cast volume alone): their hints and notes say nothing
    otherwise."""
    return state.raycast is None or state.with_surfaces


def rays_note(state) -> str | None:
    """Where a volume over the memory budget is ray cast, in a line: the rays read its bricks in view at full
    resolution, as many as the room holds (model/ray_bricks.py), and the coarse view (every step-th sample,
    model/big_volume.py) elsewhere; or the coarse view alone where it is not shown in bricks.  None where the
    volume is not ray cast or shown whole."""
    if state.raycast is None or state.volume is None or state.full_volume is None:
        return None
    shown, full = (tuple(volume.data.shape) for volume in (state.volume, state.full_volume))
    if shown == full:
        return None
    rays = _rays_in_bricks(state)
    if rays is not None:
        return (f"the volume is ray cast at full resolution in its bricks read so far, {rays.text}, and from "
                f"{shape_text(shown)} of {shape_text(full)} samples elsewhere (what the memory budget lets in)")
    return (f"the volume is ray cast from {shape_text(shown)} of {shape_text(full)} samples, the coarse view on "
            "show (what the memory budget or the GPU's limits let in)")


def _rays_in_bricks(state):
    """The rays' bricks (model/ray_bricks.py RayBricks) where the rays read some at full resolution, else None."""
    rays = state.bricks.rays if state.bricks is not None else None
    return rays if rays is not None and rays.capacity else None


def rays_line(state) -> str | None:
    """The panel's Stats line of the rays of a volume over the budget (rays_note in a tooltip), or None."""
    if rays_note(state) is None:
        return None
    rays = _rays_in_bricks(state)
    if rays is not None:
        return f"{len(rays.loaded)} of {len(rays.bricks)} bricks in full"
    return f"{shape_text(state.volume.data.shape)} (coarse view)"


MIN_RAY_SPACING, MAX_RAY_SPACING = 2, 5
"""While the view moves, one ray per N x N pixels, N in this range (N = 1: the whole picture, at rest)."""
MOVING_TARGET_MS = 100.0
"""What a frame with rays may take while the view moves (then the picture is stretched from fewer rays)."""


class RaySpacing:
    """How sparse the rays are while the view moves: the finest spacing whose moving frames stay under
    MOVING_TARGET_MS, from the frames measured.  A frame over the target spaces the rays one pixel more; one
    that would stay under it with a pixel less (its time scaled by the rays' ratio, (N / (N - 1))^2) spaces
    them one pixel less.  Only ray-cast frames drawn while moving are recorded."""

    def __init__(self):
        self.spacing = MIN_RAY_SPACING

    def record(self, frame_ms: float) -> None:
        """A moving frame drawn at `spacing` took `frame_ms`."""
        n = self.spacing
        if frame_ms > MOVING_TARGET_MS and n < MAX_RAY_SPACING:
            self.spacing = n + 1
        elif n > MIN_RAY_SPACING and frame_ms * (n / (n - 1)) ** 2 < MOVING_TARGET_MS:
            self.spacing = n - 1
