"""The viewer's state without GL: the volume on show, and the parts that say how it is shown.

Each part owns its settings and refuses a bad value with an exception (ViewerError, MeshOptionsError,
ValueError), leaving everything as it was; the panel shows the exception's one line in `error`:
- `levels`: the iso values, their looks, the selected one and its sweep (model/levels.py);
- `mesh_options`: cells, smoothing, sharp features: one `MeshOptions` (app/options.py);
- `slices`: slice planes, the window over the values, colour map, clip plane (model/slices.py);
- `labels`: a label map's layers (model/labels.py);
- `color_by`: a scalar through a colour map (model/colorby.py);
- `series`: a series' time axis: the time point, playback, its reads on a worker (model/series.py);
- `jobs`: volumes read and full-resolution exports in the background, a request id in and a response
  out (model/jobs.py); `opening`: the requests for volumes and their answers (model/opening.py);
  `saving`: "Save mesh..." and "Export full resolution" asked for (model/save_requests.py);
- `style`, `recent`, and the panel's messages (`error`, `message`).

The GPU side (gfx/scene.py) follows the state once a frame, after the panel's layout: it answers the
jobs' responses, uploads, extracts.  Nothing here touches GL, so no change made while the panel lays
itself out extracts anything, and the state can be built and tested without a GL context.
"""
from __future__ import annotations

import dataclasses

from ...core.budget import MemoryBudget, default_budget, given_budget
from ...core.sharp.features import check_feature_angle
from ...cpu.smooth import check_iterations
from ...labels import label_count_hint, labels_of, refuse_a_scan
from ...options import MeshOptions
from ...volumes import Volume
from .big_volume import every_step
from .bricks import BrickView, brick_view
from .colorby import DEFAULT_COLORMAP, SOURCES, ColorBy, make_color_by
from .errors import ViewerError
from .histogram import value_histogram
from .jobs import Jobs
from .labels import LabelMap
from .levels import Levels
from .opening import VolumeOpening
from .raycast import check_raycast, check_transfer, moved_point
from .recent import RecentFiles
from .save_requests import SaveRequests
from .series import TimeAxis
from .slices import SliceScene, SliceSettings
from .style import SurfaceStyle

GRADIENT_DIRECTIONS = ("descent", "ascent")


class ViewerState:
    """What the viewer shows, without GL: the volume on show and its levels, labels, slices, mesh options, look, time
    axis and measures, changed only through methods that refuse a bad value and keep the rest; the GPU side follows it
    once a frame."""

    def __init__(self, recent: RecentFiles | None = None, opener=None, memory_budget: MemoryBudget | None = None):
        """`opener`: reads expr: volumes in the caller's thread (the window passes open_volume with
        its GL context, to sample them on its GPU); other volumes are read on a worker thread.
        `memory_budget`: what a volume on show may take (core/budget.py); None until the GPU side sets its
        default (the GPU's memory, or half the RAM on a software renderer); by default the budget of the
        enclosing core.budget.using_budget block (a command's --memory-budget, a Python call's)."""
        self.memory_budget = memory_budget if memory_budget is not None else given_budget()
        self.refusal = None   # why the GPU side's extractor cannot hold a shape (its limits), set by it; None: any
        self.volume: Volume | None = None     # on show (downsampled, for a big one)
        self.full_volume: Volume | None = None  # a big volume shown at every `step`-th sample (big_volume.py)
        self.step = 1
        self.bricks: BrickView | None = None   # a big volume's bricks at full resolution (bricks.py)
        self.histogram = None                 # log counts of `volume`'s values, for the panel (histogram.py)
        self.label_hint = 0                   # labels in the volume if it looks like a label map, else 0
        self.volume_serial = 0                # bumps on every new volume: the window refits its camera
        self.levels = Levels()
        self.series = TimeAxis()               # a series' time axis (series.py)
        self.mesh_options = MeshOptions()
        self.slices = SliceSettings()
        self.labels = LabelMap()
        self.color_by: ColorBy | None = None
        self.style = SurfaceStyle()
        self.jobs = Jobs()
        self.opening = VolumeOpening(self, opener)   # volumes asked for, read in the background (opening.py)
        self.saving = SaveRequests(self)      # the mesh on show to save, a big volume's full resolution to export
        self.closed = False                   # surfaces capped where they leave the volume (gfx/cap_meshes.py)
        self.error: str | None = None         # shown in the panel until the next successful action
        self.message: str | None = None       # e.g. where the last screenshot went
        self.recent = recent if recent is not None else RecentFiles(None)
        self.frame_ms = 0.0
        self.gl_renderer = "unknown"          # the GPU side says which
        self.raycast: str | None = None       # a ray-casting mode drawn in the meshes' place (model/raycast.py)
        self.with_surfaces = False            # the surfaces drawn with the ray-cast volume too
        self.transfer = None                  # DVR's opacity points (value, opacity); None: the window's ramp
        self.transfer_edits = 0               # the points' moves that changed them: a frame after one is coarse

    # --- volumes -----------------------------------------------------------
    @property
    def budget(self) -> MemoryBudget:
        """The memory budget (the default of a software renderer until the GPU side sets its own)."""
        return self.memory_budget or default_budget(None, software=True)

    def show(self, volume: Volume, level: float | None = None, full_volume: Volume | None = None,
             step: int = 1) -> None:
        """Put `volume` on show (the GPU side has taken it): one level at `level` (default: the volume's
        default level, else the middle of its value range), slices fitted, no label map or colour by."""
        self.volume, self.full_volume, self.step = volume, full_volume, step
        self.bricks = brick_view(full_volume, step, self.budget, volume)
        self.label_hint = label_count_hint(volume.data)   # the panel offers "Show as labels"
        self.histogram = value_histogram(volume.data, volume.value_range)
        self.slices.fit(volume.data, volume.value_range)
        self.levels.reset(volume.value_range, level if level is not None else volume.default_level)
        self.labels.hide()
        self.color_by = None
        self.transfer = None   # a transfer function is in the values of the volume it was given for
        self.series.attach(full_volume if full_volume is not None else volume, step, volume)
        self.volume_serial += 1
        self.error = None

    @property
    def gradient_direction(self) -> str:
        """Which side of a level the object is on: "descent" (values fall outwards: inside is above the
        level, a density) or "ascent" (inside is below, a signed distance)."""
        return self.volume.gradient_direction if self.volume is not None else "descent"

    def set_gradient_direction(self, direction: str) -> bool:
        """The object's side for the volume on show (its normals turn to point out of it); whether it
        changed.  Camera and levels stay."""
        if direction not in GRADIENT_DIRECTIONS:
            raise ViewerError(f"gradient direction {direction!r} is not one of {', '.join(GRADIENT_DIRECTIONS)}")
        if self.volume is None or direction == self.volume.gradient_direction:
            return False
        self.volume.gradient_direction = direction
        return True

    # --- the selected level ---------------------------------------------------
    @property
    def value_range(self) -> tuple[float, float]:
        """The volume's value range: the slider's ends."""
        return self.levels.value_range

    @property
    def iso(self) -> float:
        """The selected level's value."""
        return self.levels.value

    @iso.setter
    def iso(self, value: float) -> None:
        """Set the selected level's value, clamped to the value range."""
        self.levels.set_value(value)   # clamped to the value range

    # --- direct volume rendering ------------------------------------------------
    def set_raycast(self, mode: str | None) -> None:
        """Draw the volume itself by ray casting in `mode` (model/raycast.py: mip, minip, mean, iso, dvr)
        in place of the meshes; None or "off": the meshes.  An unknown mode is one line; nothing changes."""
        self.raycast = check_raycast(mode)

    def set_with_surfaces(self, on: bool) -> None:
        """With a ray-casting mode, draw the surfaces too (gfx/renderer.py: the opaque ones and the slices
        end the rays, the translucent ones are blended over the volume); off: the volume alone."""
        self.with_surfaces = bool(on)

    def set_transfer(self, spec) -> None:
        """DVR's opacity over the values (model/raycast.py: a preset such as "ct-bone", "V:A,..." or pairs);
        None or "off": the window's linear ramp.  A bad one is one line; nothing changes."""
        if self.volume is None and spec not in (None, "off"):
            raise ViewerError("open a volume before giving a transfer function")
        self.transfer = check_transfer(spec, self.value_range if self.volume is not None else (0.0, 1.0))

    def move_transfer_point(self, index: int, value: float, opacity: float) -> None:
        """Move the transfer function's point `index` to (value, opacity), as the panel's drag does (kept in
        the value range, between its neighbours, opacity 0..1: model/raycast.py moved_point)."""
        if self.transfer is None:
            raise ViewerError("choose a transfer function (a preset) before moving its points")
        moved = moved_point(self.transfer, index, value, opacity, self.value_range)
        if moved != self.transfer:   # the window's next frame: a ray per 2x2 pixels (ui/app.py), as a drag's
            self.transfer_edits += 1
        self.transfer = moved

    # --- mesh options: one MeshOptions (`mesh_options`), replaced whole ---------------
    def set_cells(self, cells: str) -> bool:
        """March "cubes" or "tetrahedra" on every level; whether the options changed."""
        return self._set_mesh_options(cells=cells)

    def set_topology(self, topology: str) -> bool:
        """Decide ambiguous cells by Montani's rule ("montani") or the trilinear interpolant ("trilinear")."""
        return self._set_mesh_options(topology=topology)

    def set_smooth(self, iterations) -> bool:
        """Smooth every level's mesh `iterations` times, each projected back onto the level set."""
        return self._set_mesh_options(smooth=check_iterations(iterations))

    def set_sharp(self, angle) -> bool:
        """Extended Marching Cubes with feature angle `angle` (degrees) on every level, or None for off."""
        return self._set_mesh_options(sharp=check_feature_angle(angle))

    def _set_mesh_options(self, **change) -> bool:
        options = dataclasses.replace(self.mesh_options, **change).check()   # MeshOptionsError: nothing changes
        changed, self.mesh_options = options != self.mesh_options, options
        return changed

    # --- label map, colour by ---------------------------------------------------
    def show_labels(self, volume: Volume | None = None, names=None, force: bool = False) -> bool:
        """Show the volume on show (`volume`, if given, must be it) as a label map: every non-zero
        label's surface in its own colour, named and coloured by the label names file `names` (default:
        the one beside the volume's file, model/labels.py).  No label map raises; the view stays.  A
        volume that looks like a scan is refused unless `force` (labels.refuse_a_scan)."""
        volume = self.volume if volume is None else volume
        if volume is None:
            raise ViewerError("open a volume before showing it as a label map")
        if volume is not self.volume:
            labels_of(volume)   # no label map: say that first
            raise ViewerError(f"{volume.name} is not the volume on show; show it before showing its labels")
        refuse_a_scan(volume, force)
        self.labels.show(volume, names)
        return True

    def set_color_by(self, source: str | None, colormap: str | None = None) -> None:
        """Colour every surface by `source` through `colormap` (colorby.py): "value", "gradient", a
        volume spec of the same shape, or None for plain colours."""
        if source is None:
            self.color_by = None
            return
        if self.volume is None:
            raise ViewerError("open a volume before colouring by a scalar")
        colormap = colormap or (self.color_by.colormap if self.color_by is not None else DEFAULT_COLORMAP)
        if source in SOURCES:
            self.color_by = make_color_by(self.volume, source, colormap, spec=source)
            return
        second = self.opening.opener(source)
        if self.full_volume is not None and second.data.shape == self.full_volume.data.shape:
            second = every_step(second, self.step)   # a big volume's partner, at the step on show
        self.color_by = make_color_by(self.volume, "volume", colormap, second, spec=source)

    # --- for the renderer -------------------------------------------------------
    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The volume's box in world units: [0, (n-1) * spacing] along each axis, moved by its origin (a pyramid
        level's coarse view off the full level's grid)."""
        if self.volume is None:
            return (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
        origin = tuple(float(o) for o in self.volume.origin)
        upper = tuple((n - 1) * s + o for n, s, o in zip(self.volume.data.shape, self.volume.spacing, origin))
        return origin, upper

    @property
    def slice_scene(self) -> SliceScene | None:
        """What the renderer needs to draw the slices (None before a volume is shown)."""
        if self.volume is None:
            return None
        return SliceScene(self.volume.data, self.volume.spacing, self.slices, self.iso,
                          self.gradient_direction, self.style.front_color,
                          self.labels.cap_table() if self.labels else None, self.volume.origin)

    def release(self) -> None:
        """Let go of what the state runs outside itself: a full-resolution export still running is stopped."""
        self.saving.stop()   # the window closes: stop the export (its file is written whole or not at all)
