"""The panel's Surfaces section: the levels (select, show, colour, opacity, remove, add), colour by
and its colour bar.  Every change goes through `ViewerState`'s levels (model/levels.py) and colour by."""
from __future__ import annotations

from ..gfx.colorbar import tick_label
from ..model.colorby import SOURCES
from ..model.colormaps import COLORMAPS
from ..model.levels import MAX_LEVELS
from ..model.state import ViewerState
from .gui import act, imgui, tooltip

NEW_LEVEL_STEP = 0.1    # an added level starts this fraction of the range above the selected one
COLORBAR_HEIGHT = 14.0
COLORBAR_SEGMENTS = 64


class LevelsSection:
    def __init__(self):
        self.volume_text = ""   # the second volume to colour by

    def draw(self, state: ViewerState) -> None:
        imgui.separator_text("Surfaces")
        if state.volume is None:
            return
        levels = state.levels
        for i, level in enumerate(list(levels)):
            imgui.push_id(i)
            if imgui.radio_button("##selected", levels.selected == i):
                act(state, levels.select, i)
            tooltip("the slider and histogram edit this level")
            imgui.same_line()
            toggled, visible = imgui.checkbox("##visible", level.visible)
            if toggled:
                act(state, levels.set_visible, i, visible)
            tooltip("show / hide")
            imgui.same_line()
            changed, color = imgui.color_edit3("##color", list(levels.color(i, state.style.front_color)),
                                               imgui.ColorEditFlags_.no_inputs)
            if changed:
                act(state, levels.set_color, i, color)
            imgui.same_line()
            imgui.set_next_item_width(135)  # wide enough that the grab at 1.00 leaves the text readable
            changed, opacity = imgui.slider_float("##opacity", level.opacity, 0.0, 1.0, "opacity %.2f")
            if changed:
                act(state, levels.set_opacity, i, opacity)
            imgui.same_line()
            imgui.text(f"{level.value:.4g}")
            if len(levels) > 1:
                imgui.same_line()
                if imgui.small_button("x"):
                    act(state, levels.remove, i)
            imgui.pop_id()
        if len(levels) < MAX_LEVELS and imgui.button("Add surface"):
            low, high = state.value_range
            act(state, levels.add, min(state.iso + NEW_LEVEL_STEP * (high - low), high))
        self._color_by(state)

    def _color_by(self, state: ViewerState) -> None:
        current = state.color_by.source if state.color_by is not None else "off"
        imgui.set_next_item_width(150)
        if imgui.begin_combo("colour by", current):
            for choice in ("off", *SOURCES):
                if imgui.selectable(choice, choice == current)[0]:
                    act(state, state.set_color_by, None if choice == "off" else choice)
            imgui.end_combo()
        imgui.set_next_item_width(-imgui.calc_text_size("Colour by it").x - 2 * imgui.get_style().frame_padding.x
                                  - imgui.get_style().item_spacing.x)
        entered, self.volume_text = imgui.input_text_with_hint(
            "##second", "a volume of the same shape", self.volume_text, imgui.InputTextFlags_.enter_returns_true)
        imgui.same_line()
        if (imgui.button("Colour by it") or entered) and self.volume_text.strip():
            act(state, state.set_color_by, self.volume_text.strip())
        if state.color_by is None:
            return
        imgui.set_next_item_width(150)
        if imgui.begin_combo("colour map", state.color_by.colormap):
            for name in COLORMAPS:
                if imgui.selectable(name, name == state.color_by.colormap)[0]:
                    act(state, state.set_color_by, state.color_by.spec, name)
            imgui.end_combo()
        _colorbar(state.color_by)


def _colorbar(color_by) -> None:
    """The map as a horizontal bar, its end values under it."""
    left_top = imgui.get_cursor_screen_pos()
    width = imgui.get_content_region_avail().x
    draw = imgui.get_window_draw_list()
    lut = color_by.lut
    for k in range(COLORBAR_SEGMENTS):
        r, g, b = lut[min(k * len(lut) // COLORBAR_SEGMENTS, len(lut) - 1)]
        x0 = left_top.x + width * k / COLORBAR_SEGMENTS
        x1 = left_top.x + width * (k + 1) / COLORBAR_SEGMENTS
        draw.add_rect_filled(imgui.ImVec2(x0, left_top.y), imgui.ImVec2(x1 + 1, left_top.y + COLORBAR_HEIGHT),
                             imgui.get_color_u32(imgui.ImVec4(float(r), float(g), float(b), 1.0)))
    imgui.dummy(imgui.ImVec2(width, COLORBAR_HEIGHT))
    low, high = color_by.value_range
    start_x = imgui.get_cursor_pos_x()
    imgui.text(tick_label(low, low, high))
    for text, at in ((color_by.source, 0.5), (tick_label(high, low, high), 1.0)):
        imgui.same_line(start_x + max((width - imgui.calc_text_size(text).x) * at, 0.0))
        imgui.text(text)

