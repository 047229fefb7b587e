"""What slices show, as the panel and the command line set it: three axis-aligned planes, a window
over the values for the colour map, the map, and a clip plane.  No GL here (gfx/slices.py draws it).

Values from centre - window/2 to centre + window/2 span the colour map: the field's "window/level",
whose words the command line's flags and the panel keep; the code calls the window's middle its
`centre`, as "level" is the iso value.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ...errors import InputError
from .colormaps import check_colormap

AXES = "xyz"  # array axes 0, 1, 2 as the flags and the panel name them
WINDOW_PERCENTILES = (0.5, 99.5)   # the default window spans these percentiles of the values
MAX_PERCENTILE_SAMPLES = 1 << 21


def default_window(data: np.ndarray, value_range: tuple[float, float]) -> tuple[float, float]:
    """(window, centre) spanning WINDOW_PERCENTILES of the values: a scan's few extreme voxels do
    not wash out the rest.  Big volumes are sampled on a regular sub-grid, read into memory (a dask array's
    percentile works along one axis only)."""
    step = 1
    while data.size > MAX_PERCENTILE_SAMPLES * step**3:
        step += 1
    low, high = np.percentile(np.asarray(data[::step, ::step, ::step]), WINDOW_PERCENTILES)
    if not high > low:
        low, high = value_range
    window = float(high - low) if high > low else 1.0
    return window, float(low + high) / 2


@dataclass
class Clip:
    """The clip plane: the surface is hidden on one side of the index `position` along `axis` (above it, with
    `hide_above`)."""
    axis: int = 2
    position: float = 0.0      # array index along `axis`; may be fractional
    hide_above: bool = True    # hide the surface where the index is above `position` (else below)

    def plane(self, spacing, origin=(0.0, 0.0, 0.0)) -> tuple[float, float, float, float]:
        """(a, b, c, d): a world point p is kept where a*px + b*py + c*pz + d >= 0; `origin`: where the volume's
        index 0 lies (Volume.origin)."""
        sign = -1.0 if self.hide_above else 1.0
        normal = [0.0, 0.0, 0.0]
        normal[self.axis] = sign
        return (*normal, -sign * (self.position * spacing[self.axis] + origin[self.axis]))


@dataclass
class SliceSettings:
    """What slices show: the panel and the command line change it through these methods, which check
    each value against the volume on show (`fit` records its shape) and raise a one-line ValueError
    for one that does not fit, changing nothing."""
    shown: list[bool] = field(default_factory=lambda: [False, False, False])
    index: list[int] = field(default_factory=lambda: [0, 0, 0])
    active: int = 2            # the slice in the 2-D view
    window: float = 1.0
    centre: float = 0.5        # the value at the colour map's middle
    colormap: str = "gray"
    clip: Clip | None = None   # None: the surface is whole
    inset: bool = True         # the 2-D view of the active slice, bottom right
    shape: tuple[int, int, int] = (2, 2, 2)

    def fit(self, data: np.ndarray, value_range: tuple[float, float]) -> None:
        """A new volume: slices (and the clip) to the middle, the window to its values."""
        self.shape = tuple(data.shape)
        self.index = [(n - 1) // 2 for n in self.shape]
        if self.clip is not None:
            self.clip.position = (self.shape[self.clip.axis] - 1) / 2
        self.window, self.centre = default_window(data, value_range)

    def show(self, axis: int, shown: bool = True, index: int | None = None) -> None:
        """Show or hide the slice across `axis`, at array index `index` if given, and make it the active one; an index
        outside the volume is an InputError naming the axis's range."""
        if index is not None:
            n = self.shape[axis]
            if not (float(index).is_integer() and 0 <= index < n):
                raise InputError(f"slice {AXES[axis]}={index} is outside the volume; "
                                 f"{AXES[axis]} runs from 0 to {n - 1}")
            self.index[axis] = int(index)
        self.shown[axis] = bool(shown)
        self.active = axis

    def set_clip(self, axis: int | None, position: float | None = None, hide_above: bool = True) -> None:
        """Clip at `position` (default: the middle) along `axis`; axis None removes the clip."""
        if axis is None:
            self.clip = None
            return
        n = self.shape[axis]
        position = (n - 1) / 2 if position is None else float(position)
        if not 0 <= position <= n - 1:
            raise InputError(f"clip {AXES[axis]}={position:g} is outside the volume; "
                             f"{AXES[axis]} runs from 0 to {n - 1}")
        self.clip = Clip(axis, position, hide_above)

    def set_window(self, window: float | None, centre: float | None = None) -> None:
        """The width of the values the colour map spans, and their middle (None: as it is)."""
        window = self.window if window is None else float(window)
        centre = self.centre if centre is None else float(centre)
        if not (np.isfinite(window) and window > 0 and np.isfinite(centre)):
            raise InputError(f"window {window:g} must be a positive number (and the level finite)")
        self.window, self.centre = window, centre

    def set_colormap(self, name: str) -> None:
        """Use colour map `name` for the slices; a name isoscope does not have is refused (`check_colormap`)."""
        check_colormap(name)
        self.colormap = name

    def planes(self, caps: bool = True) -> list[tuple[int, float, bool]]:
        """(axis, index, cap) of every plane to draw: the shown slices, then the clip's cut (a cap:
        drawn only inside the object; not with `caps` False, for the volume ray cast alone)."""
        planes = [(axis, float(self.index[axis]), False) for axis in range(3) if self.shown[axis]]
        if self.clip is not None and caps:
            planes.append((self.clip.axis, self.clip.position, True))
        return planes

    def inset_axis(self) -> int | None:
        """The slice in the 2-D view: the active one if shown, else the first shown."""
        if not self.inset or not any(self.shown):
            return None
        return self.active if self.shown[self.active] else self.shown.index(True)


class SliceScene(NamedTuple):
    """What the renderer needs to draw slices: ViewerState.slice_scene."""
    data: np.ndarray
    spacing: tuple[float, float, float]
    settings: SliceSettings
    iso: float                 # the isocurve's level
    gradient_direction: str    # which side of it is inside ("descent": above)
    curve_color: tuple[float, float, float]
    label_caps: tuple | None = None   # a label map's (labels, RGBA): the clip's cut in their colours
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)   # where index 0 lies in the scene (Volume.origin)
