"""The panel's Mesh section (cells, smoothing, sharp features) and its Labels section (a label map's
surfaces, each shown or hidden).  Every change goes through `ViewerState`."""
from __future__ import annotations

from ...options import CELLS
from ..gfx.state import ViewerState
from .gui import imgui
from .levels_panel import tooltip

MAX_SMOOTH_SLIDER = 10
DEFAULT_SHARP_ANGLE = 30.0
SHARP_ANGLES = (5.0, 90.0)   # the slider's span; the API takes any angle in (0, 180)


class MeshSection:
    def __init__(self):
        self.sharp_angle = DEFAULT_SHARP_ANGLE   # kept while sharp features are off

    def draw(self, state: ViewerState) -> None:
        # Folded until opened: the panel must stay short enough for the slices below it.
        if not imgui.collapsing_header("Mesh: cells, smoothing, sharp features"):
            return
        imgui.set_next_item_width(150)
        if imgui.begin_combo("cells", state.cells):
            for cells in CELLS:
                if imgui.selectable(cells, cells == state.cells)[0]:
                    state.set_cells(cells)
            imgui.end_combo()
        tooltip("tetrahedra: six per cube, no ambiguous cells, about 3x the triangles")
        imgui.set_next_item_width(150)
        changed, smooth = imgui.slider_int("smoothing", state.smooth, 0, MAX_SMOOTH_SLIDER)
        if changed:
            state.set_smooth(smooth)
        tooltip("iterations, each projected back onto the level set: fewer sliver triangles, same surface")
        toggled, sharp = imgui.checkbox("sharp features", state.sharp is not None)
        if toggled:
            state.set_sharp(self.sharp_angle if sharp else None)
        tooltip("Extended Marching Cubes (Kobbelt et al. 2001): edges and corners of cells whose\n"
                 "normals open wider than the angle are kept; full-resolution meshes only")
        if state.sharp is not None:
            imgui.same_line()
            imgui.set_next_item_width(110)
            _, self.sharp_angle = imgui.slider_float("##angle", self.sharp_angle, *SHARP_ANGLES, "%.0f deg")
            if imgui.is_item_deactivated_after_edit():   # the feature step is numpy: once, on release
                state.set_sharp(self.sharp_angle)


class LabelsSection:
    def draw(self, state: ViewerState) -> None:
        if not state.label_layers:
            return
        self.draw_list(state)

    @staticmethod
    def offer(state: ViewerState) -> None:
        """In the Volume section: a volume that looks like a label map can be shown as one."""
        if state.label_hint and not state.label_layers and state.volume is not None:
            if imgui.button(f"Show as a label map ({state.label_hint} labels)"):
                state.show_labels(state.volume)
            tooltip("one closed surface per label, in its own colour (as --labels)")

    def draw_list(self, state: ViewerState) -> None:
        imgui.separator_text("Labels")
        for layer in state.label_layers:
            imgui.push_id(layer.label)
            toggled, visible = imgui.checkbox("##visible", layer.visible)
            if toggled:
                state.set_label_visible(layer.label, visible)
            imgui.same_line()
            imgui.color_button("##color", imgui.ImVec4(*layer.color, 1.0), imgui.ColorEditFlags_.no_tooltip)
            imgui.same_line()
            imgui.text(f"label {layer.label}  {layer.mesh.n_triangles:,} triangles")
            imgui.pop_id()
        if imgui.button("Isosurface instead"):
            state.hide_labels()
