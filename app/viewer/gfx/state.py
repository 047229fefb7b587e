"""The viewer's state: the volume on show, its surface on the GPU, the iso value, display flags, messages.

The panel, the keys and the tests all change the viewer through this object;
the window loop calls `update()` once a frame, which re-extracts whenever the
iso value changed since the last extraction (so dragging the slider re-extracts
on every frame in which the value moved, and never when it did not).  With
`level_of_detail` on (the window), a value that keeps moving is extracted from a
coarser copy of the volume when the full mesh is big, and the full mesh comes back
once the value has rested for `REST_S` (see surface.py).
"""
from __future__ import annotations

import math
from pathlib import Path

import moderngl

from ...cpu.sharp.features import check_feature_angle
from ...cpu.smooth import check_iterations
from ...gpu.mesh import GpuMesh
from ...labels import label_count_hint
from ...options import MeshOptions
from ...volumes import Volume, open_volume
from ..model.big_volume import FullResolutionExport, viewer_level
from ..model.histogram import value_histogram
from ..model.recent import RecentFiles
from ..model.slices import SliceSettings
from ..model.style import SurfaceStyle
from .label_layers import LabelLayers
from .levels import SurfaceLevels, SurfaceLook
from .loading import USER_ERRORS, PendingLoad, one_line
from .slices import SliceScene
from .surface import GpuSurface

ANIMATION_PERIOD_S = 6.0          # one sweep up and back down
ANIMATION_SPAN = (0.02, 0.98)     # fractions of the range; the very ends give empty surfaces
REST_S = 0.15                     # a value unchanged this long gets its full-resolution mesh


class IsoAnimation:
    """The space key's sweep of the iso value up and down the range, eased at the ends."""

    def __init__(self):
        self.running = False
        self._phase = 0.0

    def start(self, iso: float, value_range: tuple[float, float]) -> None:
        # Start the sweep from the current value so the surface does not jump.
        low, high = value_range
        start, end = ANIMATION_SPAN
        fraction = ((iso - low) / (high - low) - start) / (end - start) if high > low else 0.0
        self._phase = math.acos(1 - 2 * min(max(fraction, 0.0), 1.0)) / (2 * math.pi)
        self.running = True

    def advance(self, dt_seconds: float, value_range: tuple[float, float]) -> float:
        """The iso value `dt_seconds` further along the sweep."""
        self._phase = (self._phase + dt_seconds / ANIMATION_PERIOD_S) % 1.0
        low, high = value_range
        start, end = ANIMATION_SPAN
        sweep = (1 - math.cos(2 * math.pi * self._phase)) / 2  # 0 -> 1 -> 0, eased at the ends
        return low + (high - low) * (start + (end - start) * sweep)


class ViewerState(SurfaceLevels, LabelLayers):
    def __init__(self, ctx: moderngl.Context, recent: RecentFiles | None = None, level_of_detail: bool = False):
        self.ctx = ctx                   # the context the surface's buffers must live in (the window's)
        self.volume: Volume | None = None
        self.surface: GpuSurface | None = None  # the GL side of `volume`
        self.histogram = None            # log counts of `volume`'s values, for the panel (histogram.py)
        self.iso = 0.0
        self._extracted_iso: float | None = None
        self.smooth = 0                  # smoothing iterations, projected onto the level set (re-extracts)
        self.level_of_detail = level_of_detail  # coarse meshes while the value moves (the window)
        self._moved_last_frame = False
        self._rest_s = 0.0               # how long the value has not moved
        self.style = SurfaceStyle()
        self.slices = SliceSettings()    # slice planes, window/level, colour map, clip (slices.py)
        self.animation = IsoAnimation()
        self.error: str | None = None    # shown in the panel until the next successful action
        self.message: str | None = None  # e.g. where the last screenshot went
        self.recent = recent if recent is not None else RecentFiles(None)
        self.volume_serial = 0           # bumps on every new volume: the window refits its camera
        self.frame_ms = 0.0
        self.gl_renderer = ctx.info.get("GL_RENDERER", "unknown")
        self.loading: PendingLoad | None = None  # a volume being read in the background
        self.cells = "cubes"             # what the extractors march: "cubes" or "tetrahedra"
        self.sharp: float | None = None  # Extended MC's feature angle, degrees (None: plain meshes)
        self.label_layers = []           # a label map's surfaces, when one is on show (label_layers.py)
        self.full_volume: Volume | None = None   # a big volume shown downsampled (big_volume.py)
        self.label_hint = 0              # labels in the volume on show if it looks like a label map, else 0
        self.exporting: FullResolutionExport | None = None  # its full-resolution export, running
        self.levels, self.selected = [], 0      # the surfaces on show, and the one the slider moves (levels.py)
        self.color_by = None                     # colour by a scalar through a colour map (colorby.py)

    # --- volumes -----------------------------------------------------------
    def open(self, spec: str, **open_options) -> bool:
        """Open a built-in name, file path or 'expr:...'; on failure keep the current volume and set `error`."""
        try:
            # ctx: an expr: volume is sampled on the GPU in the viewer's own context.
            volume = open_volume(spec, ctx=self.ctx, **open_options)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        except Exception as exc:  # a loader's bug (a RecursionError) must not close the window: as PendingLoad
            self.error = f"could not open {spec[:80]}: {type(exc).__name__}: {one_line(exc)[:200]}"
            return False
        shown = self.show(volume)
        if shown and _names_a_file(spec):
            self.recent.add(spec)
        return shown

    def open_in_background(self, spec: str, **open_options) -> None:
        """Like `open`, but read on a worker thread: the panel shows a progress bar meanwhile, and
        `update` puts the volume on show (or its error in the panel) when it is read.  expr:
        volumes are sampled on the GPU, in this thread's context, so they open at once."""
        if spec.strip().lower().startswith("expr:"):
            self.open(spec, **open_options)
            return
        self.loading = PendingLoad(spec, open_options)
        self.error = None

    def _finish_loading(self) -> None:
        pending, self.loading = self.loading, None
        if pending.error is not None:
            self.error = pending.error  # the volume on show stays
        elif self.show(pending.volume) and Path(pending.spec).is_file():
            self.recent.add(pending.spec)

    def show(self, volume: Volume, iso: float | None = None) -> bool:
        """Upload `volume` to the GPU and extract its first surface; the old volume stays on failure.
        A volume too big to drag live is shown downsampled (big_volume.py), the full one kept in
        `full_volume` for 'Export full resolution'."""
        try:
            shown, step = viewer_level(volume)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        if not self._upload(shown, shown.gradient_direction):
            return False
        self.full_volume = volume if step > 1 else None
        volume = shown
        self.label_hint = label_count_hint(volume.data)   # the panel offers "Show as labels"
        self.histogram = value_histogram(volume.data, volume.value_range)
        self.slices.fit(volume.data, self.value_range)
        low, high = self.value_range
        first_iso = iso if iso is not None else volume.default_level
        self.iso = (low + high) / 2 if first_iso is None else min(max(float(first_iso), low), high)
        self._reset_levels()
        self._release_labels()
        self._release_color_by()
        self.volume_serial += 1
        self.update(0.0, wait=True)
        return self.error is None

    @property
    def inside_below(self) -> bool:
        """True when the object is where values are below the level (a signed distance)."""
        return self.volume is not None and self.volume.gradient_direction == "ascent"

    def set_inside_below(self, below: bool) -> bool:
        """Say which side of the level the object is on, for the volume on show: its normals turn
        to point out of it.  Camera and iso value stay."""
        direction = "ascent" if below else "descent"
        if self.volume is None or direction == self.volume.gradient_direction:
            return False
        if not self._upload(self.volume, direction):
            return False
        self.volume.gradient_direction = direction
        try:
            self._refresh_levels()
        except USER_ERRORS as exc:   # the other levels' meshes stay as they were; the selected one follows
            self.error = one_line(exc)
        self.update(0.0, wait=True)
        return self.error is None

    def set_cells(self, cells: str) -> bool:
        """March "cubes" or "tetrahedra" (every level, from the same resident volume: no re-upload)."""
        problem = MeshOptions(cells=cells, smooth=self.smooth, sharp=self.sharp).problem()
        if problem is not None:
            return self._refuse(problem)
        self.cells = cells
        return self._apply_mesh_options()

    def set_smooth(self, iterations) -> bool:
        """Smooth every level's mesh `iterations` times, each projected back onto the level set."""
        try:
            iterations = check_iterations(iterations)
        except ValueError as exc:
            return self._refuse(one_line(exc))
        problem = MeshOptions(cells=self.cells, smooth=iterations, sharp=self.sharp).problem()
        if problem is not None:
            return self._refuse(problem)
        self.smooth = iterations
        return self._apply_mesh_options()

    def set_sharp(self, angle) -> bool:
        """Extended Marching Cubes with feature angle `angle` (degrees) on every level, or None for off."""
        try:
            angle = check_feature_angle(angle)
        except ValueError as exc:
            return self._refuse(one_line(exc))
        problem = MeshOptions(cells=self.cells, smooth=self.smooth, sharp=angle).problem()
        if problem is not None:
            return self._refuse(problem)
        self.sharp = angle
        return self._apply_mesh_options()

    def _apply_mesh_options(self) -> bool:
        """The surface's extractions follow `cells`, `smooth` and `sharp`: every level is extracted again."""
        options = (self.cells, self.smooth, self.sharp)
        self.error = None
        if self.surface is None:
            return True
        before = (self.surface.cells, self.surface.smooth, self.surface.sharp)
        if before != options:
            self.surface.cells, self.surface.smooth, self.surface.sharp = options
            try:
                self._refresh_levels()
            except USER_ERRORS as exc:   # e.g. a mesh too big to smooth on this GPU: back to what was shown
                self.cells, self.smooth, self.sharp = before
                self.surface.cells, self.surface.smooth, self.surface.sharp = before
                self._refresh_levels()
                return self._refuse(one_line(exc))
            self.update(0.0, wait=True)
        return self.error is None

    def _upload(self, volume: Volume, gradient_direction: str) -> bool:
        """A new GPU surface for `volume` replaces the old one; on failure the old one stays."""
        try:
            surface = GpuSurface(self.ctx, volume, gradient_direction)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        surface.cells, surface.smooth, surface.sharp = self.cells, self.smooth, self.sharp
        if self.surface is not None:
            self.surface.release()
        self.volume, self.surface = volume, surface
        self._extracted_iso = None
        self.error = None
        return True

    # --- iso ---------------------------------------------------------------
    @property
    def value_range(self) -> tuple[float, float]:
        return self.surface.value_range if self.surface is not None else (0.0, 1.0)

    def set_iso(self, value: float) -> None:
        low, high = self.value_range
        self.iso = min(max(float(value), low), high)

    def nudge_iso(self, fraction_of_range: float) -> None:
        low, high = self.value_range
        self.set_iso(self.iso + fraction_of_range * (high - low))

    @property
    def animating(self) -> bool:
        return self.animation.running

    def toggle_animation(self) -> None:
        if self.animation.running:
            self.animation.running = False
        else:
            self.animation.start(self.iso, self.value_range)

    # --- per frame ---------------------------------------------------------
    def update(self, dt_seconds: float, wait: bool = False) -> bool:
        """Advance the animation and re-extract if the iso value moved (or the full mesh is due
        after a preview); True when it re-extracted.  Sharp features are made on a worker thread (the
        plain mesh shows until they are in) unless `wait`, as after a change of the mesh options."""
        if self.loading is not None and self.loading.done():
            self._finish_loading()
        if self.exporting is not None and self.exporting.done():
            self._finish_export()
        if self.surface is None or self.label_layers:   # a label map draws its labels, not the level
            return False
        try:
            self.surface.poll()   # sharp features made on the worker since the last frame
        except USER_ERRORS as exc:   # the plain mesh stays on show
            self.error = one_line(exc)
        if self.animation.running:
            self.iso = self.animation.advance(dt_seconds, self.value_range)
        moved = self.iso != self._extracted_iso or self.smooth != self.surface.smooth
        if moved:
            # A value that moved in the last frame too is being dragged (or animated): a preview
            # will do.  A single change (a key, a typed value, a new volume) gets the full mesh.
            preview = self.level_of_detail and self._moved_last_frame
            self._rest_s = 0.0
        else:
            self._rest_s += dt_seconds
            if self.surface.shown_step == 1 or self._rest_s < REST_S:
                self._moved_last_frame = False
                return False
            preview = False  # rested long enough: back to full resolution
        self._moved_last_frame = moved and self._extracted_iso is not None  # a new volume's first is no move
        self.surface.smooth = self.smooth
        try:
            self.surface.extract(self.iso, preview=preview, budget=self.preview_budget(), wait=wait)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            self.animation.running = False
        self._extracted_iso = self.iso  # also on failure: do not retry the same value every frame
        return True

    # --- slices, window/level, colour map, clip (slices.py) ------------------
    def show_slice(self, axis: int, shown: bool = True, index: int | None = None) -> bool:
        """Show or hide the slice across array axis `axis` (0, 1, 2 = x, y, z), at `index` if given."""
        return self._change_slices(self.slices.show, axis, shown, index)

    def set_clip(self, axis: int | None, position: float | None = None, hide_above: bool = True) -> bool:
        """Hide the surface beyond index `position` along `axis` (None: no clip); the cut shows the slice."""
        return self._change_slices(self.slices.set_clip, axis, position, hide_above)

    def set_window_level(self, window: float | None = None, level: float | None = None) -> bool:
        return self._change_slices(self.slices.set_window_level, window, level)

    def set_colormap(self, name: str) -> bool:
        return self._change_slices(self.slices.set_colormap, name)

    def _change_slices(self, change, *args) -> bool:
        """Apply a SliceSettings change; a bad value sets `error` and leaves what is shown."""
        try:
            change(*args)
        except ValueError as exc:
            self.error = one_line(exc)
            return False
        self.error = None
        return True

    @property
    def slice_scene(self) -> SliceScene | None:
        """What the renderer needs to draw the slices (None before a volume is shown)."""
        if self.volume is None:
            return None
        return SliceScene(self.volume.data, self.volume.spacing, self.slices, self.iso,
                          not self.inside_below, self.style.front_color)

    # --- saving ------------------------------------------------------------
    def export_full_resolution(self, path) -> bool:
        """Write the full-resolution mesh of a downsampled big volume at the current level to `path`,
        a chunk at a time in a child process; `update` reports when it is written (or why not)."""
        if self.full_volume is None:
            return self._refuse("the whole volume is on show; use Save mesh")
        if self.exporting is not None and not self.exporting.done():
            return self._refuse("an export is still running; wait for it to finish")
        self.exporting = FullResolutionExport(self.full_volume, self.iso, path, self.volume.gradient_direction)
        self.error = None
        return True

    def _finish_export(self) -> None:
        export, self.exporting = self.exporting, None
        if export.error is not None:
            self.error = f"full-resolution export failed: {export.error}"
        else:
            self.error, self.message = None, export.message

    # --- saving ------------------------------------------------------------
    def save_mesh(self, path) -> bool:
        """Write the surface on show (at full resolution) to `path`, in the format of its extension
        and the volume's world coordinates where its file defines them; False with `error` set."""
        from ...io.export import COLOR_FORMATS, in_volume_space, write_mesh
        if self.label_layers:   # a label map: its visible labels, in one coloured file where the format can
            return self.save_labels(path, one_file=Path(path).suffix.lower() in COLOR_FORMATS)
        if self.surface is None:
            self.error = "no surface to save yet; open a volume first"
            return False
        try:
            if self.surface.shown_step != 1:  # a preview is on show: save the full mesh at its level
                self.surface.extract(self.iso)
            verts, faces, normals, _ = self.surface.shown.read_mesh()   # cubes' or tetrahedra's
            verts, faces, normals, space = in_volume_space(self.volume, verts, faces, normals)
            write_mesh(path, verts, faces, normals, space=space)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        self.error = None
        self.message = f"mesh saved: {path} ({len(faces):,} triangles, {space} coordinates)"
        return True

    # --- what the renderer draws, and stats for the panel ---------------------
    def drawn(self) -> list[tuple[GpuMesh, SurfaceLook]]:
        """A label map's visible labels while one is on show, else the visible levels."""
        return self._shown_labels() if self.label_layers else self._shown_levels()

    @property
    def meshes(self) -> list[GpuMesh]:
        """The visible levels' (or labels') meshes; their looks: `looks`."""
        return [mesh for mesh, _ in self.drawn()]

    @property
    def looks(self) -> list[SurfaceLook]:
        """How to draw each of `meshes`, in the same order."""
        return [look for _, look in self.drawn()]

    @property
    def extractor(self):
        """The full-resolution extractor of the volume on show (None before one is shown)."""
        return self.surface.extractor if self.surface is not None else None

    @property
    def preview_step(self) -> int:
        """1 when the full-resolution mesh is on show, else the sample step of the preview."""
        return self.surface.shown_step if self.surface is not None else 1

    @property
    def n_vertices(self) -> int:
        return self.surface.shown.n_vertices if self.surface is not None else 0

    @property
    def n_triangles(self) -> int:
        return self.surface.shown.n_triangles if self.surface is not None else 0

    @property
    def extract_ms(self) -> float:
        return self.surface.shown.last_extract_ms if self.surface is not None else 0.0

    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The volume's box in world units: [0, (n-1) * spacing] along each axis."""
        if self.volume is None:
            return (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
        upper = tuple((n - 1) * s for n, s in zip(self.volume.data.shape, self.volume.spacing))
        return (0.0, 0.0, 0.0), upper

    def release(self) -> None:
        if self.exporting is not None:   # the window closes: stop the child (its file is written whole or not at all)
            self.exporting.cancel()
        self._release_levels()
        self._release_labels()
        self._release_color_by()
        if self.surface is not None:
            self.surface.release()
            self.surface = None


def _names_a_file(spec: str) -> bool:
    """Whether `spec` is a file's path (for the recent files); a 2,000-character expr: is no file name,
    and asking the file system would raise "File name too long"."""
    if spec.strip().lower().startswith("expr:"):
        return False
    try:
        return Path(spec).is_file()
    except (OSError, ValueError):
        return False
