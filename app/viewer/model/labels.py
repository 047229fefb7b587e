"""A label map on show: one surface per non-zero label of a segmentation, each with its name, colour,
opacity and shown or hidden.  While a label map is on show the scene draws its labels instead of the iso
levels (the volume stays loaded, so slices show the label values).  No GL here: the GPU side
(gfx/label_scene.py) extracts each label's surface once per label map and keeps it, so showing, hiding
or fading a label changes only what is drawn.

Names and colours come from a label names file (volumes/label_names.py: ITK-SNAP's label description
or a Slicer colour table) beside the segmentation or given; labels it does not list keep the default
palette and are called "label N".
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...labels import label_boxes, label_colors, labels_of
from ...volumes.label_names import LabelName, label_names_for
from .errors import ViewerError


@dataclass
class LabelLayer:
    """One label of a label map on show: its value, colour, whether it is drawn, its opacity and its name from the label
    file (empty when it has none)."""
    label: int
    color: tuple[float, float, float]
    visible: bool = True
    opacity: float = 1.0
    name: str = ""

    @property
    def title(self) -> str:
        """What the panel calls it: its name, else "label N"."""
        return self.name or f"label {self.label}"


class LabelMap:
    """The labels on show (none: the iso levels are drawn)."""

    def __init__(self):
        self.layers: list[LabelLayer] = []
        self.serial = 0     # bumps on every label map put on show: the GPU side extracts it again
        self.names_path: str | None = None   # the label names file given (None: the one beside it, if any)
        self._volume = None                  # the volume whose labels these are

    def __bool__(self) -> bool:
        return bool(self.layers)

    def show(self, volume, names_path=None) -> None:
        """Every non-zero label of `volume`, in label order, named and coloured by the label names file
        `names_path` (default: the one beside the volume's file, if any) or the default palette; a
        volume that is no label map (fractional values, no labels) or a bad names file raises and
        changes nothing."""
        labels = [int(value) for value, _, _ in label_boxes(labels_of(volume))[1]]
        if not labels:
            raise ViewerError(f"{volume.name} has no non-zero labels; open it without --labels for an isosurface")
        names = label_names_for(volume.source, names_path)
        if volume is not self._volume or labels != [layer.label for layer in self.layers]:
            self.serial += 1   # new surfaces; the same labels named again keep theirs
        self.layers = layers(labels, names)
        self.names_path = None if names_path is None else str(Path(names_path).expanduser().resolve())
        self._volume = volume

    def hide(self) -> None:
        """Back to the iso levels of the same volume."""
        self.layers = []

    def layer(self, label: int) -> LabelLayer:
        """The layer of label value `label`; ViewerError if that label is not on show."""
        for layer in self.layers:
            if layer.label == label:
                return layer
        raise ViewerError(f"no label {label} on show")

    def set_visible(self, label: int, visible: bool) -> None:
        """Show or hide label `label` (nothing is extracted again: the scene keeps every label's surface)."""
        self.layer(label).visible = bool(visible)

    def set_opacity(self, label: int, opacity: float) -> None:
        """0 (hidden) .. 1 (opaque); below 1 the label is drawn see-through (order-independent)."""
        opacity = float(opacity)
        if not 0.0 <= opacity <= 1.0:
            raise ViewerError(f"opacity {opacity:g} for label {label} is outside 0..1; give a value from 0 to 1")
        self.layer(label).opacity = opacity

    def visible(self) -> list[LabelLayer]:
        """The layers being drawn, in the map's order."""
        return [layer for layer in self.layers if layer.visible]

    def cap_table(self) -> tuple[np.ndarray, np.ndarray]:
        """(labels, RGBA) for the clip's cut: every label in order, and its colour with alpha 1 where its cut
        is drawn (shown and opaque: a see-through label shows its inside instead), else 0."""
        values = np.array([layer.label for layer in self.layers], np.int64)
        rgba = np.array([(*layer.color, float(layer.visible and layer.opacity >= 1.0)) for layer in self.layers],
                        np.float32).reshape(-1, 4)
        return values, rgba

    # --- a scene file's part -------------------------------------------------
    def saved(self) -> dict:
        """What a scene keeps of the labels: the names file given, and each label's look."""
        return {"names": self.names_path,
                "layers": [{"label": layer.label, "visible": layer.visible, "opacity": layer.opacity}
                           for layer in self.layers]}

    def restore(self, saved: dict) -> None:
        """A scene's labels part (`saved`) on the labels on show; labels it does not list stay as they are."""
        for item in saved.get("layers") or []:
            layer = self.layer(int(item["label"]))
            layer.visible = bool(item.get("visible", True))
            self.set_opacity(layer.label, float(item.get("opacity", 1.0)))


def layers(labels: list[int], names: dict[int, LabelName]) -> list[LabelLayer]:
    """A layer per label: the names file's name, colour, opacity and visibility where it lists the label,
    else the default palette (label_colors, over the labels in order) and "label N"."""
    palette = label_colors(len(labels))
    made = []
    for label, color in zip(labels, palette):
        entry = names.get(label)
        if entry is None:
            made.append(LabelLayer(label, tuple(map(float, color))))
        else:
            made.append(LabelLayer(label, entry.color, entry.visible, entry.opacity, entry.name))
    return made
