"""A label map on show: one surface per non-zero label of a segmentation, each in its own colour and
shown or hidden.  While a label map is on show the scene draws its labels instead of the iso levels
(the volume stays loaded, so slices show the label values).  No GL here: the GPU side (gfx/scene.py)
extracts and keeps each label's surface.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...labels import label_boxes, label_colors, labels_of
from .errors import ViewerError


@dataclass
class LabelLayer:
    label: int
    color: tuple[float, float, float]
    visible: bool = True


class LabelMap:
    """The labels on show (none: the iso levels are drawn)."""

    def __init__(self):
        self.layers: list[LabelLayer] = []
        self.serial = 0     # bumps on every label map put on show: the GPU side extracts it again

    def __bool__(self) -> bool:
        return bool(self.layers)

    def show(self, volume) -> None:
        """Every non-zero label of `volume`, in label order and its own colour; a volume that is no
        label map (fractional values, no labels) raises and changes nothing."""
        labels = [int(value) for value, _, _ in label_boxes(labels_of(volume))[1]]
        if not labels:
            raise ViewerError(f"{volume.name} has no non-zero labels; open it without --labels for an isosurface")
        colors = label_colors(len(labels))
        self.layers = [LabelLayer(label, tuple(map(float, color))) for label, color in zip(labels, colors)]
        self.serial += 1

    def hide(self) -> None:
        """Back to the iso levels of the same volume."""
        self.layers = []

    def set_visible(self, label: int, visible: bool) -> None:
        for layer in self.layers:
            if layer.label == label:
                layer.visible = bool(visible)
                return
        raise ViewerError(f"no label {label} on show")

    def visible(self) -> list[LabelLayer]:
        return [layer for layer in self.layers if layer.visible]
