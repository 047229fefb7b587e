"""The panel's Labels section: a label map's surfaces, each shown or hidden and at its opacity (below 1:
see-through), with its name from the label names file.  Every change goes through `ViewerState`; the
meshes are kept (gfx/label_scene.py), so a change shows in the next frame."""
from __future__ import annotations

from ..model.state import ViewerState
from .gui import act, imgui, tooltip

OPACITY_WIDTH = 120   # pixels: the grab at 1.00 leaves "opacity 1.00" readable


class LabelsSection:
    """The panel's Labels section: a row per label of the label map on show, to show, hide or fade it."""

    def __init__(self):
        # label -> {"visible": box, "opacity": box} as last drawn, each ((left, top), (right, bottom)) in
        # imgui units: where a pointer finds a row's controls (tests drive them through X)
        self.boxes: dict[int, dict[str, tuple]] = {}

    def draw(self, state: ViewerState, scene) -> None:
        """The label map's layers (their triangles from `scene`, gfx/scene.py)."""
        self.boxes = {}
        if not state.labels:
            return
        imgui.separator_text("Labels")
        for layer in state.labels.layers:
            imgui.push_id(layer.label)
            toggled, visible = imgui.checkbox("##visible", layer.visible)
            if toggled:
                act(state, state.labels.set_visible, layer.label, visible)
            boxes = self.boxes[layer.label] = {"visible": _item_box()}
            imgui.same_line()
            imgui.color_button("##color", imgui.ImVec4(*layer.color, 1.0), imgui.ColorEditFlags_.no_tooltip)
            imgui.same_line()
            imgui.set_next_item_width(OPACITY_WIDTH)
            changed, opacity = imgui.slider_float("##opacity", layer.opacity, 0.0, 1.0, "opacity %.2f")
            if changed:
                act(state, state.labels.set_opacity, layer.label, opacity)
            boxes["opacity"] = _item_box()
            imgui.same_line()
            imgui.text(layer.title)
            tooltip(f"label {layer.label}: {scene.stats.label_triangles(layer.label):,} triangles")
            imgui.pop_id()
        if imgui.button("Isosurface instead"):
            state.labels.hide()

    @staticmethod
    def offer(state: ViewerState) -> None:
        """In the Volume section: a volume that looks like a label map can be shown as one."""
        if state.label_hint and not state.labels and state.volume is not None:
            if imgui.button(f"Show as a label map ({state.label_hint} labels)"):
                act(state, state.show_labels)
            tooltip("one closed surface per label, in its own colour (as --labels)")


def _item_box() -> tuple:
    return tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max())
