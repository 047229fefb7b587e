"""Label maps in the viewer: one coloured, closed surface per label of a segmentation.

The labels part of `ViewerState` (a mixin, as `levels.SurfaceLevels` is): `show_labels` puts a
label map on show (the volume itself stays loaded, so slices show the label values), and while
labels are on show the scene draws their surfaces instead of the iso levels.  Each label can be
hidden; `save_labels` writes one file per label, or one file with per-vertex colours.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...gpu.mesh import GpuMesh
from ...labels import check_label_output, label_surfaces, labels_of, write_labelled
from .label_scene import label_scene
from .levels import SurfaceLook
from .loading import USER_ERRORS, one_line


@dataclass
class LabelLayer:
    label: int
    mesh: GpuMesh
    color: tuple[float, float, float]
    visible: bool = True


class LabelLayers:
    """Mixin for ViewerState: uses its ctx, volume, error and message."""

    label_layers: list[LabelLayer]

    def show_labels(self, volume) -> bool:
        """Show `volume` as a label map: every non-zero label's surface in its own colour.  On a bad
        volume (fractional values, no labels) the one-line `error` is set and the view stays."""
        try:
            surfaces = label_surfaces(labels_of(volume), spacing=volume.spacing)
            if not surfaces:
                raise ValueError(f"{volume.name} has no non-zero labels; open it without --labels for an isosurface")
            if self.volume is not volume and not self.show(volume):
                return False
            scene = label_scene(self.ctx, surfaces)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        self._release_labels()
        self.label_layers = [LabelLayer(label, mesh, color) for label, mesh, color in scene]
        self.error = None
        return True

    def hide_labels(self) -> None:
        """Back to the iso levels of the same volume."""
        self._release_labels()

    def set_label_visible(self, label: int, visible: bool) -> bool:
        for layer in self.label_layers:
            if layer.label == label:
                layer.visible = bool(visible)
                return True
        self.error = f"no label {label} on show"
        return False

    def label_counts(self) -> tuple[int, int, int]:
        """(labels shown, vertices, triangles) of the visible labels' surfaces: the stats of what is drawn."""
        shown = [layer.mesh for layer in self.label_layers if layer.visible]
        return len(shown), sum(m.n_vertices for m in shown), sum(m.n_triangles for m in shown)

    def _shown_labels(self) -> list[tuple[GpuMesh, SurfaceLook]]:
        return [(layer.mesh, SurfaceLook(layer.color, 1.0)) for layer in self.label_layers if layer.visible]

    def save_labels(self, path, one_file: bool = False) -> bool:
        """The visible labels' surfaces, in the volume's world space: STEM_label<N>.EXT each, or with
        `one_file` all in `path` (PLY, GLB) with per-vertex colours.  False with `error` set."""
        from ...io.export import in_volume_space
        layers = [layer for layer in self.label_layers if layer.visible]
        try:
            check_label_output(path, one_file)
            if not layers:
                raise ValueError("no label is visible; tick the labels to save")
            placed = [in_volume_space(self.volume, *layer.mesh.read()[:3]) for layer in layers]
            meshes = {layer.label: mesh[:3] for layer, mesh in zip(layers, placed)}
            written = write_labelled(path, meshes, [layer.color for layer in layers], placed[0][3], one_file)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        self.error = None
        self.message = f"saved {len(layers)} label surface(s): {', '.join(p.name for p, _, _ in written)}"
        return True

    def _release_labels(self) -> None:
        for layer in getattr(self, "label_layers", []):
            layer.mesh.release()
        self.label_layers = []
