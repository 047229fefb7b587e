"""What a `GpuScene` shows, in numbers, for the panel's Stats, the window's title and the tests: the selected level's
vertices, triangles and extraction time, each level's, the samples on screen, the label map's counts."""
from __future__ import annotations

from ...core.budget import shown_shape
from ...gpu.mesh import GpuMesh
from .renderer import SurfaceLook


class SceneStats:
    """The numbers of what `scene` (a GpuScene) shows, read when asked."""

    def __init__(self, scene):
        self.scene = scene

    @property
    def meshes(self) -> list[GpuMesh]:
        """The visible levels' (or labels') meshes; their looks: `looks`."""
        return [mesh for mesh, _ in self.scene.drawn()]

    @property
    def looks(self) -> list[SurfaceLook]:
        """The looks of what is drawn, in drawing order."""
        return [look for _, look in self.scene.drawn()]

    @property
    def preview_step(self) -> int:
        """1 when the full-resolution mesh is on show, else the sample step of the preview."""
        surface = self.scene.surface
        return surface.shown_step if surface is not None else 1

    @property
    def shown_shape(self) -> tuple[int, int, int] | None:
        """The samples along each axis of the surface on screen: the volume on show (every `state.step`-th
        sample of a volume over the memory budget), fewer while a preview is on show; None with no volume."""
        volume = self.scene.state.volume
        if volume is None:
            return None
        bricks = self.scene.state.bricks
        if bricks is not None and self.scene.bricks.drawing and bricks.full_in_view:   # each brick in view refined
            return tuple(self.scene.state.full_volume.data.shape)
        return shown_shape(volume.data.shape, self.preview_step)

    @property
    def n_vertices(self) -> int:
        """The selected level's vertices on show (0 with no surface): in bricks, those of each buffer drawn (the
        coarse remainder's ranges share one)."""
        surface = self.scene.surface
        if surface is not None and self.scene.bricks.drawing:
            return sum({mesh.vertex_buffer: mesh.n_vertices for mesh in self.scene.bricks.meshes}.values())
        return surface.shown.n_vertices if surface is not None else 0

    @property
    def n_triangles(self) -> int:
        """The selected level's triangles on show (0 with no surface): in bricks, those of the coarse remainder,
        the bricks at full resolution and the skirts."""
        surface = self.scene.surface
        if surface is not None and self.scene.bricks.drawing:
            return self._brick_triangles()
        return surface.shown.n_triangles if surface is not None else 0

    def _brick_triangles(self) -> int:
        return sum(mesh.n_triangles for mesh in self.scene.bricks.meshes)

    @property
    def extract_ms(self) -> float:
        """How long the selected level's last extraction took, in milliseconds."""
        surface = self.scene.surface
        return surface.shown.last_extract_ms if surface is not None else 0.0

    def level_stats(self, index: int) -> tuple[int, float]:
        """(triangles, extraction ms) of the mesh on show for level `index`."""
        scene = self.scene
        level = scene.state.levels[index]
        triangles, ms = scene.level_meshes.stats(level, scene.surface)
        if scene.bricks.drawing and level is scene.level_meshes.on_extractor:   # drawn in bricks
            return self._brick_triangles(), ms
        return triangles, ms

    def label_triangles(self, label: int) -> int:
        """The triangles of label `label`'s surface."""
        return self.scene.labels.triangles(label)

    def label_counts(self) -> tuple[int, int, int]:
        """(labels shown, vertices, triangles) of the visible labels' surfaces: the stats of what is drawn."""
        return self.scene.labels.counts(self.scene.state.labels)
