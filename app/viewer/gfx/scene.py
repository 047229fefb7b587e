"""The GPU side of a `ViewerState`: the volume on the GPU, each level's mesh, a label map's surfaces and
colour by's textures, brought in line with the state once a frame.

`update` runs after the panel's layout (the window's frame loop, a headless render): it answers the
state's background jobs (a volume read: uploaded and put on show; an export: its message), follows
what changed (the object's side: uploaded again; the mesh options: every level made again; another
level selected: the one that leaves keeps its mesh), advances the animation and re-extracts the
selected level when its value moved, on every frame in which it moved and never when it did not.
With `previews` (the window), a value that keeps moving is extracted from a coarser copy of the
volume (surface.py), every step-th sample: the finest step whose measured frame time stays under the
target (model/pacing.py; each frame's time, the `dt_seconds` of the next `update`, is recorded against
the step it drew); the full mesh comes back once the value has rested for `REST_S`, `SAID_FRAMES`
frames after the status line says it is being made (the extraction stalls the frame it runs in: the word
is on screen meanwhile), and the status line then says what it took.

All levels come from the one `GpuSurface` (one upload, one set of brick ranges, one extractor and its
previews), or, on a context below OpenGL 4.3 (macOS's 4.1: no compute shaders), from its CPU twin
`CpuSurface` (cpu_surface.py), whose meshes are uploaded into vertex buffers of the same layout.
The selected level is drawn straight from the extractor's buffers, every other level from a copy of its own
(level_meshes.py).  Its parts: the preview's step (preview_pacing.py), its numbers for the panel
(`stats`, scene_stats.py), saving what it shows (saving.py).

`show` and saving raise what goes wrong; `update`, the frame's step, shows it in the panel
(`state.error`) and keeps what was drawn.
"""
from __future__ import annotations

import dataclasses

import moderngl

from ...gpu.context import gl_summary, has_compute, is_software_renderer
from ...gpu.memory import default_memory_budget
from ...gpu.mesh import GpuMesh
from ...volumes import Volume
from ..model.big_volume import downsampled
from ..model.errors import USER_ERRORS as STATE_ERRORS
from ..model.errors import one_line
from ..model.opening import Opened
from ..model.series import take_time_point, time_step
from ..model.state import ViewerState
from . import surface as surface_module
from .brick_surface import BrickSurface
from .cap_meshes import CapMeshes
from .colorby import GpuColorBy
from .cpu_surface import CpuSurface
from .label_scene import LabelMeshes
from .level_meshes import LevelMeshes
from .preview_pacing import REST_S, PreviewPacing
from .renderer import SurfaceLook
from .saving import save_mesh
from .scene_stats import SceneStats
from .surface import GpuSurface

USER_ERRORS = (*STATE_ERRORS, moderngl.Error)
"""What a bad volume, value or extraction raises: one-line messages meant for the user."""
SAID_FRAMES = 2
"""Frames between the status line's "full resolution: extracting..." and the extraction: the window lays
out its panel before the scene follows the state, so a word said in one frame's update shows in the next
frame's picture; the extraction waits for the frame after that, and the word is on screen while it runs."""


class GpuScene:
    """The GPU side of a `ViewerState`: brought in line with it once a frame by `update`; `drawn` gives the renderer
    each visible mesh with its look."""

    def __init__(self, ctx: moderngl.Context, state: ViewerState, previews: bool = False):
        self.ctx, self.state = ctx, state
        self.previews = previews   # coarse meshes while the value moves (the window)
        # The panel's Stats: the driver, its OpenGL version and which extractor makes the meshes.
        state.gl_renderer = f"{ctx.info.get('GL_RENDERER', 'unknown')} ({gl_summary(ctx)})"
        if state.memory_budget is None:   # what a volume may take here: the GPU's memory (gpu/memory.py)
            state.memory_budget = default_memory_budget(ctx)
        elif is_software_renderer(ctx) and not state.memory_budget.software:   # a given one, spent in RAM
            state.memory_budget = dataclasses.replace(state.memory_budget, software=True)
        # Below OpenGL 4.3 (no compute shaders: macOS's 4.1) the meshes are made on the CPU (cpu_surface.py), and
        # so are those of mesh options the GPU extractor does not make (`GpuSurface.makes`).
        self._compute = has_compute(ctx)
        # A volume the GPU extractor cannot hold whole is shown downsampled, as one over the budget.
        state.refusal = surface_module.extractor_refusal(ctx) if self._compute else None
        self.surface: GpuSurface | CpuSurface | None = None   # the GL side of state.volume
        self.color_by: GpuColorBy | None = None  # the textures of state.color_by
        self.caps = CapMeshes(ctx)                # the levels' caps while state.closed (cap_meshes.py)
        self.bricks = BrickSurface(ctx)           # a big volume's bricks at full resolution (brick_surface.py)
        self.options = state.mesh_options         # what the meshes on the GPU were made with
        self.level_meshes = LevelMeshes(ctx)      # which level the extractor holds, the other levels' copies
        self._extracted: float | None = None      # the value it was extracted at (None: extract it again)
        # a label map's surfaces, kept while it is on show; coarse twins where a frame of them is slow
        self.labels = LabelMeshes(ctx, previews and is_software_renderer(ctx))
        self._wait = False                        # the next extraction makes its sharp features at once
        self._moved_last_frame = False
        self._rest_s = 0.0                        # how long the value has not moved
        self.pacing = PreviewPacing()             # frame times while the level moves, per preview step
        self._full_said: str | None = None        # the status line's word on the full mesh, while it stands
        self._said_frames = 0                     # frames since it said the full mesh is coming
        self.stats = SceneStats(self)             # its numbers, for the panel's Stats

    # --- volumes -----------------------------------------------------------
    def show(self, volume: Volume, level: float | None = None) -> None:
        """Upload `volume` and extract its first level (at `level`, default the volume's own); the old
        volume stays on a failed upload.  A volume too big to drag live is shown downsampled
        (big_volume.py), the full one kept for 'Export full resolution'."""
        shown, step = downsampled(volume, self.state.budget, self.state.refusal)
        self.show_opened(Opened("", volume, shown, step), level)

    def show_opened(self, opened: Opened, level: float | None = None) -> None:
        """`show` of a volume read (and downsampled) by an "open" job."""
        surface = self._new_surface(opened.shown, opened.shown.gradient_direction)
        self._release_meshes()
        self.bricks.clear()   # the last volume's bricks are not drawn over the new one's level
        if self.surface is not None:
            self.surface.release()
        self.surface = surface
        self.state.show(opened.shown, level, opened.volume if opened.step > 1 else None, opened.step)
        self.level_meshes.on_extractor, self._extracted = self.state.levels.current, None
        self.pacing.pace.forget()   # another volume: other frame times
        self._extract_selected(0.0, wait=True)

    # --- per frame ---------------------------------------------------------
    def update(self, dt_seconds: float, wait: bool = False) -> bool:
        """Bring the GPU in line with the state (see the module's docstring); True when the selected
        level was extracted.  Sharp features are made on a worker thread (the plain mesh shows until
        they are in) unless `wait`, or after a change of the mesh options."""
        state = self.state
        for response in state.jobs.poll():
            self._attempt(self._answer_open if response.kind == "open" else state.saving.exported, response)
        self._attempt(self._follow_time, dt_seconds, wait)
        self._attempt(self._follow)
        self.labels.follow_look(state.labels, dt_seconds, wait)
        if state.saving.save_request is not None:
            path, state.saving.save_request = state.saving.save_request, None
            self._attempt(save_mesh, self, path)
        try:
            return self._extract_selected(dt_seconds, wait)
        except USER_ERRORS as exc:
            state.error = one_line(exc)
            state.levels.animation.running = False
            return True

    def _answer_open(self, response) -> None:
        self.show_opened(self.state.opening.opened(response))

    def _attempt(self, step, *args) -> None:
        try:
            step(*args)
        except USER_ERRORS as exc:
            self.state.error = one_line(exc)

    def _follow_time(self, dt_seconds: float, wait: bool) -> None:
        """A series' time point, read on a worker (model/series.py), uploaded in place of the one on show:
        levels, slices, clip, camera and mesh options stay; each level's mesh is made again (previews
        while playing, as while a value is dragged)."""
        point = time_step(self.state, dt_seconds, wait)
        if point is not None:
            self._replace_surface(point.shown, self.state.gradient_direction)
            take_time_point(self.state, point)
            self._moved_last_frame = self.state.series.playing
            self._refresh_copies()

    def _follow(self) -> None:
        state = self.state
        if self.surface is None:
            return
        if state.gradient_direction != self.surface.gradient_direction:
            self._upload_again()
        if state.mesh_options != self.options:
            self._apply_mesh_options()
        meshes = self.level_meshes
        meshes.drop_gone(state.levels.items)
        if state.levels.current is not meshes.on_extractor:
            self._move_extractor()
        for level in list(state.levels.items):   # levels added between two frames (a scene, a script)
            if level is not meshes.on_extractor and level not in meshes.copies:
                self._extracted = None   # the extractor leaves the selected level for it
                try:
                    meshes.keep(level, self.surface, self.options)
                except USER_ERRORS:   # as _move_extractor: a level that cannot have a mesh goes
                    state.levels.restore([item for item in state.levels.items if item is not level],
                                         state.levels.current)
                    raise
        self.labels.follow(state.labels, state.volume)
        self._follow_color_by()

    def _upload_again(self) -> None:
        """The object's side changed: the volume uploaded again with its new gradient direction (a
        failed upload puts the old side back); camera and levels stay."""
        volume = self.state.volume
        try:
            surface = self._new_surface(volume, volume.gradient_direction)
        except BaseException:
            volume.gradient_direction = self.surface.gradient_direction
            raise
        self.surface.release()
        self.surface = surface
        self._extracted, self._wait = None, True
        self._refresh_copies()

    def _surface_kind(self):
        """GpuSurface where it makes the state's mesh options (and compute shaders run), else CpuSurface."""
        return GpuSurface if self._compute and GpuSurface.makes(self.state.mesh_options) else CpuSurface

    def _new_surface(self, volume: Volume, gradient_direction: str):
        """The GL side of `volume`, of `_surface_kind`."""
        return self._surface_kind()(self.ctx, volume, gradient_direction)

    def _replace_surface(self, volume: Volume, gradient_direction: str) -> None:
        """A new surface for `volume` in place of the one on show (its size kept: it sizes the preview before
        the first mesh)."""
        surface = self._new_surface(volume, gradient_direction)
        surface.full_triangles = self.surface.full_triangles
        self.surface.release()
        self.surface = surface

    def _apply_mesh_options(self) -> None:
        """Every level made again with the state's mesh options (on the CPU's surface where the GPU's does not
        make them); on failure (e.g. a mesh too big to smooth on this GPU) the options and meshes go back to
        what was shown."""
        before, self.options = self.options, self.state.mesh_options
        self._extracted, self._wait = None, True
        try:
            self._surface_for_options()
            self._refresh_copies()
        except USER_ERRORS:
            self.options = self.state.mesh_options = before
            self._surface_for_options()
            self._refresh_copies()
            raise

    def _surface_for_options(self) -> None:
        """The surface's kind (GPU or CPU extractor) swapped where the mesh options need the other."""
        if type(self.surface) is not self._surface_kind():
            self._replace_surface(self.state.volume, self.surface.gradient_direction)

    def _refresh_copies(self) -> None:
        self.level_meshes.refresh(self.surface, self.options)
        self._extracted = None

    def _move_extractor(self) -> None:
        """Another level was selected (or added): the one leaving the extractor keeps its full mesh in
        its own buffers.  If that fails (e.g. out of GPU memory), the selection goes back and a level
        that never had a mesh goes: nothing changes."""
        levels, meshes = self.state.levels, self.level_meshes
        leaving = meshes.on_extractor
        if leaving is not None and leaving in levels.items:
            try:
                meshes.keep(leaving, self.surface, self.options)
            except USER_ERRORS:
                levels.restore([level for level in levels if level is leaving or level in meshes.copies], leaving)
                raise
        meshes.on_extractor, self._extracted, self._moved_last_frame = levels.current, None, False

    def _follow_color_by(self) -> None:
        wanted = self.state.color_by
        shown = self.color_by.color_by if self.color_by is not None else None
        if wanted is shown:
            return
        try:
            textures = GpuColorBy(self.ctx, wanted) if wanted is not None else None
        except BaseException:
            self.state.color_by = shown
            raise
        if self.color_by is not None:
            self.color_by.release()
        self.color_by = textures

    def _extract_selected(self, dt_seconds: float, wait: bool) -> bool:
        state = self.state
        if self.surface is None or state.labels:   # a label map draws its labels, not the levels
            return False
        try:
            self.surface.poll()   # sharp features made on the worker since the last frame
        except USER_ERRORS as exc:   # the plain mesh stays on show
            state.error = one_line(exc)
        state.levels.animate(dt_seconds)
        self.pacing.record_frame(dt_seconds, (self.level_meshes.preview_budget(), self.options))
        value = state.iso
        moved = value != self._extracted
        if moved:
            # A moving value (a drag, an animation, Play, keys pressed in turn) gets a preview where its frames
            # would be slow (`PreviewPacing.step`), its first change too: a 512x512x400 CT's full mesh took 0.25-0.4 s,
            # a stall at the start of every drag.  The full mesh follows once it rests.  A new volume's first
            # extraction, and any without previews (headless renders), are full.
            preview = self.previews and self._extracted is not None
            self._rest_s = 0.0
            if self._full_said is not None and state.message == self._full_said:
                state.message = None   # the last full mesh's word is not about the preview on show
            self._full_said = None
        else:
            self._rest_s += dt_seconds
            # A frame with a preview on show that extracts nothing times the frame's floor (model/pacing.py): all
            # but the preview's extraction.  One drawing the full mesh does not: that mesh is no drag's.
            self._moved_last_frame, self.pacing.last_frame = False, 0 if self.surface.shown_step > 1 else None
            if self.surface.shown_step == 1 or self._rest_s < REST_S:
                return False
            if self._full_said is None:   # rested: the status line says the full mesh is coming...
                shape = "x".join(map(str, state.volume.data.shape))
                self._full_said = state.message = f"full resolution: extracting {shape} samples..."
                self._said_frames = 0
            if self._said_frames < SAID_FRAMES:   # ...and is drawn before the frame whose extraction stalls
                self._said_frames += 1
                return False
            preview = False  # rested long enough: back to full resolution
        self._moved_last_frame = moved and self._extracted is not None  # a new volume's first is no move
        self._extracted, wait, self._wait = value, wait or self._wait, False  # no retry of a failed value
        step = self.pacing.step(self.surface, self.level_meshes.preview_budget()) if preview else 1
        self.surface.extract(value, self.options, step=step, wait=wait)
        # A frame that drew a preview (or a full mesh while moving) is timed by the next update; one that made
        # a step's extractor (an upload) or the full mesh at rest says nothing about a drag's frames.
        timed = self._moved_last_frame and not self.surface.made_preview
        self.pacing.last_frame = self.surface.shown_step if timed else None
        if not moved:
            shown = self.surface.shown
            self._full_said = state.message = (f"full resolution: {shown.n_triangles:,} triangles in "
                                               f"{shown.last_extract_ms:.0f} ms")
        return True

    # --- what the renderer draws ---------------------------------------------
    def drawn(self) -> list[tuple[GpuMesh, SurfaceLook]]:
        """A label map's visible labels while one is on show, else the visible levels."""
        state = self.state
        if state.labels:
            coarse = not self.labels.resting   # just toggled or faded: the coarse twins, if it has them
            return [(mesh, SurfaceLook(layer.color, layer.opacity, origin=state.volume.origin))
                    for mesh, layer in self.labels.drawn(state.labels, coarse)]
        shown = []
        for i, level in enumerate(state.levels):
            mesh = self.level_meshes.mesh(level, self.surface) if level.visible else None
            if mesh is not None:
                in_bricks = self.bricks.drawing and level is self.level_meshes.on_extractor
                # the volume's meshes placed at its origin; the bricks' are placed already (brick_surface.py)
                look = SurfaceLook(state.levels.color(i, state.style.front_color), level.opacity, self.color_by,
                                   (0.0, 0.0, 0.0) if in_bricks else state.volume.origin)
                shown.extend((part, look) for part in (self.bricks.meshes if in_bricks else [mesh]))
        return shown + self.caps.drawn(state, self.color_by)

    def follow_bricks(self) -> None:
        """The bricks' buffers brought in line with the state's bricks (after the app's `look` at them)."""
        volume = self.state.volume
        self._attempt(self.bricks.follow, self.state.bricks, self.surface, volume.spacing if volume is not None
                      else None, volume.origin if volume is not None else (0.0, 0.0, 0.0))

    @property
    def extractor(self):
        """The full-resolution extractor of the volume on show (None before one is shown)."""
        return self.surface.extractor if self.surface is not None else None

    # --- releasing ---------------------------------------------------------
    def _release_meshes(self) -> None:
        self.level_meshes.release()
        self.labels.release()
        if self.color_by is not None:
            self.color_by.release()
            self.color_by = None

    def release(self) -> None:
        """Free the scene's GL objects: the levels' meshes, the caps, the surface and its extractors."""
        self._release_meshes()
        self.caps.release()
        self.bricks.release()
        if self.surface is not None:
            self.surface.release()
            self.surface = None
