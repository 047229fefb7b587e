"""The panel's Mesh section (cells, smoothing, sharp features: the state's one `MeshOptions`).
Every change goes through `ViewerState`."""
from __future__ import annotations

from ...options import CELLS, TOPOLOGIES
from ..model.state import ViewerState
from .gui import act, choose, imgui, px, section, tooltip

MAX_SMOOTH_SLIDER = 10
DEFAULT_SHARP_ANGLE = 30.0
SHARP_ANGLES = (5.0, 90.0)   # the slider's span; the API takes any angle in (0, 180)
COMBO_WIDTH = 150.0
MESH_TITLE = "Mesh: cells, topology, smoothing, sharp features"
SLIDER_WIDTH = 110.0


class MeshSection:
    """The panel's Mesh section: cells, topology, smoothing and sharp features."""

    def __init__(self):
        self.sharp_angle = DEFAULT_SHARP_ANGLE   # kept while sharp features are off
        self.sharp_box = None   # the sharp features checkbox's ((left, top), (right, bottom)) while it shows

    def draw(self, state: ViewerState) -> None:
        """Lay out the section (folded until opened) and change `state` through its setters, each refusal shown beside
        its control."""
        # Folded until opened: the panel must stay short enough for the slices below it.
        self.sharp_box = None
        if not section(MESH_TITLE, default_open=False):
            return
        imgui.set_next_item_width(px(COMBO_WIDTH))
        choose(state, "cells", state.mesh_options.cells, CELLS, state.set_cells)
        tooltip("tetrahedra: six per cube, no ambiguous cells, about 3x the triangles")
        imgui.set_next_item_width(px(COMBO_WIDTH))   # always drawn: the section never moves under the pointer
        choose(state, "topology", state.mesh_options.topology, TOPOLOGIES, state.set_topology)
        tooltip("how ambiguous cells are decided: montani, every ambiguous face one way (fast);\n"
                "trilinear, the field's own topology between the samples (MC33): pieces, cavities\n"
                "and handles in Measure as the data has them; cubes only, made on the CPU here")
        # Sliders write their value beside them, never under their grab.
        imgui.set_next_item_width(px(SLIDER_WIDTH))
        changed, smooth = imgui.slider_int("##smoothing", state.mesh_options.smooth, 0, MAX_SMOOTH_SLIDER, "")
        if changed:
            act(state, state.set_smooth, smooth)
        tooltip("iterations, each projected back onto the level set: fewer sliver triangles, same surface")
        imgui.same_line()
        imgui.text(f"{state.mesh_options.smooth:2d} smoothing")
        toggled, sharp = imgui.checkbox("sharp features", state.mesh_options.sharp is not None)
        self.sharp_box = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
        if toggled:
            act(state, state.set_sharp, self.sharp_angle if sharp else None)
        tooltip("Extended Marching Cubes (Kobbelt et al. 2001): edges and corners of cells whose\n"
                 "normals open wider than the angle are kept; full-resolution meshes only")
        if state.mesh_options.sharp is not None:
            imgui.same_line()
            imgui.set_next_item_width(px(SLIDER_WIDTH) - imgui.calc_text_size("90 deg").x)
            _, angle = imgui.slider_float("##angle", self.sharp_angle, *SHARP_ANGLES, "")
            self.sharp_angle = float(round(angle))
            if imgui.is_item_deactivated_after_edit():   # the feature step is numpy: once, on release
                act(state, state.set_sharp, self.sharp_angle)
            imgui.same_line()
            imgui.text(f"{self.sharp_angle:.0f} deg")
