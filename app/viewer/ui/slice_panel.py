"""The panel's Slices section: the three slice planes, the window over the values, colour map and the
clip plane.  Every change goes through the state's `SliceSettings` (model/slices.py), which check it
against the volume.
"""
from __future__ import annotations

from ..model.colormaps import COLORMAPS
from ..model.raycast import RAYCAST_MODES
from ..model.slices import AXES, default_window
from ..model.state import ViewerState
from .gui import act, choose, imgui, px, section, tooltip
from .transfer_panel import TransferEditor

CLIP_SIDES = ("hide above", "hide below")
AXIS_WIDTH = 50.0


class SlicePanel:
    """The panel's Slices section: the three slices, their window and colour map, the clip plane, ray casting and its
    transfer function."""

    def __init__(self):
        self.checkbox_boxes: dict[int, tuple[tuple[float, float], tuple[float, float]]] = {}  # axis -> rect
        self.transfer = TransferEditor()   # DVR's transfer function over the histogram (transfer_panel.py)

    def draw(self, state: ViewerState) -> None:
        """Lay out the section (nothing with no volume) and change `state` through its setters."""
        self.checkbox_boxes = {}
        self.transfer.box = None
        if not section("Slices") or state.volume is None:
            return
        settings = state.slices
        # The index beside each slider, in a column as wide as the largest: no grab covers it.
        index_width = imgui.calc_text_size(str(max(settings.shape) - 1)).x
        spacing = imgui.get_style().item_spacing.x
        for axis in range(3):
            toggled, shown = imgui.checkbox(f"{AXES[axis]}##slice", settings.shown[axis])
            self.checkbox_boxes[axis] = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
            if toggled:
                act(state, settings.show, axis, shown)
            imgui.same_line()
            imgui.set_next_item_width(-index_width - spacing)
            moved, index = imgui.slider_int(f"##slice{axis}", settings.index[axis], 0, settings.shape[axis] - 1, "")
            if moved:   # moving a slice shows it, in the 2-D view too
                act(state, settings.show, axis, True, index)
            imgui.same_line()
            text = str(settings.index[axis])
            imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + index_width - imgui.calc_text_size(text).x)
            imgui.text(text)
        settings.inset = imgui.checkbox("2-D view of the last moved slice", settings.inset)[1]

        low, high = state.value_range
        span = max(high - low, 1e-12)
        # "window" and "level" are the field's words (and the command line's flags); the code's
        # word for the window's middle is its centre: "level" is the iso value.
        changed_w, window = imgui.drag_float("window", settings.window, span / 400, span * 1e-4, span * 4, "%.4g")
        changed_c, centre = imgui.drag_float("level", settings.centre, span / 400, low - span, high + span, "%.4g")
        if changed_w or changed_c:
            act(state, settings.set_window, window, centre)
        tooltip("values level -+ window/2 span the colour map (drag, or ctrl+click to type)")
        if imgui.button("auto window"):
            act(state, settings.set_window, *default_window(state.volume.data, state.value_range))
        imgui.same_line()
        imgui.set_next_item_width(-1)
        choose(state, "##colormap", settings.colormap, COLORMAPS, settings.set_colormap)
        # The volume itself through the same colour map and window (gfx/raycast.py).
        choose(state, "volume rendering", state.raycast or "off", ("off", *RAYCAST_MODES), state.set_raycast)
        tooltip("the volume itself, ray cast in the surfaces' place: the largest (mip), smallest or mean value\n"
                "along each ray, or emission-absorption (dvr), through the colour map and window above;\n"
                "iso: the level's first hit on the interpolant, shaded (no mesh made)")
        if state.raycast is not None:
            toggled, on = imgui.checkbox("surfaces too", state.with_surfaces)
            if toggled:
                act(state, state.set_with_surfaces, on)
            tooltip("the surfaces with the volume: the opaque ones (and the slices) end the rays, mip and mean\n"
                    "cover them as much as they are bright; translucent ones are blended over the volume")
        if state.raycast == "dvr":
            self.transfer.draw(state)
        self._clip(state)

    @staticmethod
    def _clip(state: ViewerState) -> None:
        clip = state.slices.clip
        toggled, on = imgui.checkbox("clip", clip is not None)
        if toggled:
            act(state, state.slices.set_clip, 2 if on else None)
        if clip is None:
            return
        imgui.same_line()
        imgui.set_next_item_width(px(AXIS_WIDTH))
        choose(state, "##clip_axis", AXES[clip.axis], AXES,
               lambda name: state.slices.set_clip(AXES.index(name), None, clip.hide_above))
        imgui.same_line()
        imgui.set_next_item_width(-1)
        side = CLIP_SIDES[0 if clip.hide_above else 1]
        choose(state, "##clip_side", side, CLIP_SIDES,
               lambda name: state.slices.set_clip(clip.axis, clip.position, name == CLIP_SIDES[0]))
        text = f"{clip.position:.1f}"
        width = imgui.calc_text_size(f"{state.slices.shape[clip.axis] - 1:.1f}").x
        imgui.set_next_item_width(-width - imgui.get_style().item_spacing.x)
        moved, position = imgui.slider_float("##clip_position", clip.position, 0.0,
                                             float(state.slices.shape[clip.axis] - 1), "")
        if moved:
            act(state, state.slices.set_clip, clip.axis, position, clip.hide_above)
        imgui.same_line()
        imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + width - imgui.calc_text_size(text).x)
        imgui.text(text)
