"""Several surfaces of the one resident volume: up to `MAX_LEVELS` levels, each with its colour, opacity, visibility.

All levels come from the one `GpuSurface` (one upload, one set of brick ranges, one extractor
and its previews).  The selected level is the one the slider, keys and animation move
(`ViewerState.iso`): it is drawn straight from the extractor's buffers, with coarse previews
while dragging as before.  Every other level keeps its last full-resolution mesh in buffers of
its own (`MeshCopy`, a GPU-to-GPU copy made when it stops being the selected one), so the
extractor is free for the level that moves and a drag re-extracts one level per frame, not all.

`ViewerState` mixes in `SurfaceLevels`: every change (add, remove, select, colour, opacity,
visibility, colour by) goes through these methods, which refuse bad values with a one-line
`error` and keep what was on show.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import moderngl

from ...core.layout import INDEX_BYTES, VERTEX_BYTES
from ...gpu.mesh import GpuMesh
from ...volumes import open_volume
from ..model.big_volume import viewer_level
from . import surface as surface_module
from .colorby import DEFAULT_COLORMAP, SOURCES, ColorBy, make_color_by
from .loading import USER_ERRORS, one_line

MAX_LEVELS = 4
MIN_PREVIEW_SHARE = 8   # the moving level's preview keeps at least 1/8 of the frame's triangle budget
# Colours of added levels (the first level takes the style's front colour): far apart in hue.
PALETTE = ((0.95, 0.80, 0.45), (0.55, 0.85, 0.55), (0.85, 0.55, 0.85), (0.95, 0.55, 0.45))


class MeshCopy:
    """A mesh copied on the GPU into buffers of its own (grown by half again as needed)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.vertex_buffer = ctx.buffer(reserve=VERTEX_BYTES)
        self.index_buffer = ctx.buffer(reserve=INDEX_BYTES)
        self.n_vertices = self.n_triangles = 0

    def take(self, mesh: GpuMesh) -> None:
        for attr, size in (("vertex_buffer", mesh.n_vertices * VERTEX_BYTES),
                           ("index_buffer", mesh.n_triangles * INDEX_BYTES)):
            if getattr(self, attr).size < size:
                getattr(self, attr).release()
                setattr(self, attr, self.ctx.buffer(reserve=int(size * 1.5)))
        if mesh.n_triangles:
            self.ctx.copy_buffer(self.vertex_buffer, mesh.vertex_buffer, mesh.n_vertices * VERTEX_BYTES)
            self.ctx.copy_buffer(self.index_buffer, mesh.index_buffer, mesh.n_triangles * INDEX_BYTES)
        self.n_vertices, self.n_triangles = mesh.n_vertices, mesh.n_triangles

    @property
    def mesh(self) -> GpuMesh:
        return GpuMesh(self.vertex_buffer, self.index_buffer, self.n_vertices, self.n_triangles)

    def release(self) -> None:
        self.vertex_buffer.release()
        self.index_buffer.release()


@dataclass
class SurfaceLevel:
    iso: float
    color: tuple[float, float, float] | None = None   # None: the style's front colour
    opacity: float = 1.0
    visible: bool = True
    copy: MeshCopy | None = field(default=None, repr=False)  # its mesh while another level is selected
    n_triangles: int = 0       # of that copy
    extract_ms: float = 0.0    # of the extraction it was copied from


@dataclass(frozen=True)
class SurfaceLook:
    """How the renderer draws one mesh."""
    color: tuple[float, float, float]
    opacity: float
    color_by: ColorBy | None = None


class SurfaceLevels:
    """The levels part of `ViewerState` (a mixin: it uses the state's surface, iso, style and error)."""

    levels: list[SurfaceLevel]
    selected: int
    color_by: ColorBy | None

    # --- reading -----------------------------------------------------------
    def level_values(self) -> list[float]:
        """Every level's value; the selected one is the state's iso."""
        return [self.iso if i == self.selected else level.iso for i, level in enumerate(self.levels)]

    def level_color(self, index: int) -> tuple[float, float, float]:
        color = self.levels[index].color
        return self.style.front_color if color is None else color

    def level_stats(self, index: int) -> tuple[int, float]:
        """(triangles, extraction ms) of the mesh on show for level `index`."""
        if index == self.selected:
            return self.n_triangles, self.extract_ms
        return self.levels[index].n_triangles, self.levels[index].extract_ms

    def _level_mesh(self, index: int) -> GpuMesh | None:
        if self.surface is None:
            return None
        if index == self.selected:
            return self.surface.mesh
        copy = self.levels[index].copy
        return copy.mesh if copy is not None else None

    def _shown_levels(self) -> list[tuple[GpuMesh, SurfaceLook]]:
        shown = []
        for i, level in enumerate(self.levels):
            mesh = self._level_mesh(i) if level.visible else None
            if mesh is not None:
                shown.append((mesh, SurfaceLook(self.level_color(i), level.opacity, self.color_by)))
        return shown

    def preview_budget(self) -> int:
        """Triangles the moving level's preview may have: the frame's budget less what the other
        visible levels draw (full meshes), so a drag's frame time stays bounded with several."""
        others = sum(level.n_triangles for i, level in enumerate(self.levels)
                     if i != self.selected and level.visible and level.opacity > 0)
        budget = surface_module.PREVIEW_TRIANGLES
        return max(budget - others, budget // MIN_PREVIEW_SHARE)

    # --- changing ----------------------------------------------------------
    def _reset_levels(self) -> None:
        """A new volume: one level, the state's iso, in the style's colour."""
        self._release_levels()
        self.levels, self.selected = [SurfaceLevel(self.iso)], 0

    def add_level(self, value: float) -> bool:
        """A new level at `value`, selected (the slider now moves it)."""
        if self.surface is None:
            return self._refuse("open a volume before adding a surface")
        if len(self.levels) >= MAX_LEVELS:
            return self._refuse(f"at most {MAX_LEVELS} surfaces at once; remove one before adding another")
        if not self._level_in_range(value) or not self._kept_selected_mesh():
            return False
        self.levels.append(SurfaceLevel(float(value), PALETTE[(len(self.levels) - 1) % len(PALETTE)]))
        self._select(len(self.levels) - 1)
        return True

    def remove_level(self, index: int) -> bool:
        if not self._level_exists(index):
            return False
        if len(self.levels) == 1:
            return self._refuse("the last surface cannot be removed; hide it instead")
        level = self.levels.pop(index)
        if level.copy is not None:
            level.copy.release()
        if index == self.selected:   # the level after it (or the new last one) takes the slider
            self._select(min(index, len(self.levels) - 1))
        elif index < self.selected:
            self.selected -= 1
        return True

    def select_level(self, index: int) -> bool:
        """The slider edits level `index` from now on."""
        if not self._level_exists(index):
            return False
        if index != self.selected:
            if not self._kept_selected_mesh():
                return False
            self._select(index)
        return True

    def set_level_color(self, index: int, color) -> bool:
        if not self._level_exists(index):
            return False
        color = tuple(float(c) for c in color)
        if len(color) != 3 or not all(0.0 <= c <= 1.0 for c in color):
            return self._refuse(f"colour {color} is not three values 0..1; pick an RGB colour")
        self.levels[index].color = color
        return True

    def set_level_opacity(self, index: int, opacity: float) -> bool:
        if not self._level_exists(index):
            return False
        if not 0.0 <= float(opacity) <= 1.0:
            return self._refuse(f"opacity {opacity:g} is outside 0..1; 1 is opaque, 0 invisible")
        self.levels[index].opacity = float(opacity)
        return True

    def set_level_visible(self, index: int, visible: bool) -> bool:
        if not self._level_exists(index):
            return False
        self.levels[index].visible = bool(visible)
        return True

    def set_color_by(self, source: str | None, colormap: str | None = None) -> bool:
        """Colour every surface by `source` through `colormap` (colorby.py): "value", "gradient", a
        volume spec of the same shape, or None for plain colours."""
        if source is not None and self.volume is None:
            return self._refuse("open a volume before colouring by a scalar")
        colormap = colormap or (self.color_by.colormap if self.color_by is not None else DEFAULT_COLORMAP)
        try:
            if source is None:
                color_by = None
            elif source in SOURCES:
                color_by = make_color_by(self.ctx, self.volume, source, colormap, spec=source)
            else:
                second = open_volume(source, ctx=self.ctx)
                if self.full_volume is not None and second.data.shape == self.full_volume.data.shape:
                    second = viewer_level(second)[0]   # a big volume's partner, at the step on show
                color_by = make_color_by(self.ctx, self.volume, "volume", colormap, second, spec=source)
        except USER_ERRORS as exc:
            return self._refuse(one_line(exc))
        self._release_color_by()
        self.color_by, self.error = color_by, None
        return True

    def _release_color_by(self) -> None:
        if getattr(self, "color_by", None) is not None:
            self.color_by.release()
        self.color_by = None

    # --- helpers -----------------------------------------------------------
    def _refuse(self, message: str) -> bool:
        self.error = message
        return False

    def _level_exists(self, index: int) -> bool:
        if 0 <= index < len(self.levels):
            return True
        return self._refuse(f"there is no surface {index + 1}; there are {len(self.levels)}")

    def _level_in_range(self, value: float) -> bool:
        low, high = self.value_range
        if not low <= float(value) <= high:
            return self._refuse(f"level {float(value):g} is outside the value range {low:g} .. {high:g}; "
                                "pick a value inside it")
        return True

    def _kept_selected_mesh(self) -> bool:
        """`_keep_selected_mesh`, or False with a one-line `error` (e.g. out of GPU memory): nothing changes."""
        try:
            self._keep_selected_mesh()
        except USER_ERRORS as exc:
            return self._refuse(one_line(exc))
        return True

    def _keep_selected_mesh(self) -> None:
        """Copy the selected level's full-resolution mesh into its own buffers, before the extractor
        moves on to another level."""
        level = self.levels[self.selected]
        level.iso = self.iso
        if self.surface.shown_step != 1 or self.surface.shown_cells != self.surface.cells \
                or self.surface.shown.level != self.iso:
            self.surface.extract(self.iso)
        self.surface.settle()  # sharp features still on the worker: the copy must have them
        if level.copy is None:
            level.copy = MeshCopy(self.ctx)
        level.copy.take(self.surface.mesh)
        level.n_triangles, level.extract_ms = self.surface.mesh.n_triangles, self.surface.shown.last_extract_ms

    def _select(self, index: int) -> None:
        """Make level `index` the one on the extractor: it is extracted afresh by the next update."""
        self.selected = index
        self.iso = self.levels[index].iso
        self._extracted_iso = None          # extract it at full resolution, not as a preview
        self._moved_last_frame = False
        self.animation.running = False
        self.error = None

    def _refresh_levels(self) -> None:
        """After a new upload (object side changed): every other level's copy extracted again."""
        for i, level in enumerate(self.levels):
            if i != self.selected and level.copy is not None:
                self.surface.extract(level.iso)
                level.copy.take(self.surface.mesh)
                level.n_triangles, level.extract_ms = level.copy.n_triangles, self.surface.shown.last_extract_ms
        self._extracted_iso = None

    def _release_levels(self) -> None:
        for level in getattr(self, "levels", []):
            if level.copy is not None:
                level.copy.release()
                level.copy = None
