"""The panel's Surfaces section: the levels (select, show, colour, opacity, remove, add), colour by
and its colour bar.  Every change goes through `ViewerState`'s levels (model/levels.py) and colour by.

Each row writes its level as the iso slider does (model/formats.py) and flags a surface that shows
nothing (model/hints.py): "empty" (no surface at that level) or "hidden" (inside an opaque one)."""
from __future__ import annotations

from ..gfx.colorbar import tick_label
from ..model.colorby import SOURCES
from ..model.colormaps import COLORMAPS
from ..model.formats import level_text
from ..model.hints import empty_level_hint, enclosing_levels
from ..model.levels import MAX_LEVELS
from ..model.raycast import surfaces_drawn
from ..model.state import ViewerState
from .gui import act, choose, imgui, px, section, tooltip

NEW_LEVEL_STEP = 0.1    # an added level starts this fraction of the range above the selected one
COLORBAR_HEIGHT = 14.0
COLORBAR_SEGMENTS = 64
OPACITY_WIDTH = 44.0
COMBO_WIDTH = 150.0
FLAG_COLOR = imgui.ImVec4(0.95, 0.75, 0.35, 1.0)


class LevelsSection:
    """The panel's Levels section: a row per iso level (value, colour, opacity, shown), the colour-by volume, and flags
    for levels whose mesh is empty or hidden inside another."""

    def __init__(self):
        self.volume_text = ""   # the second volume to colour by
        self.flags: dict[int, str] = {}   # the rows flagged last frame: level index -> "empty" or "hidden"
        self.hidden_in: dict[int, int] = {}   # a hidden level's index -> the opaque level's it lies in

    def draw(self, state: ViewerState, scene=None) -> None:
        """The rows; `scene` (gfx/scene.py), if given, says which levels' meshes are empty."""
        self.flags, self.hidden_in = {}, {}
        if state.volume is not None:   # also while folded: the status line tells of the selected level
            self.flags = self.flagged(state, scene)
            self.hidden_in = _enclosing(state, [i for i, flag in self.flags.items() if flag == "empty"])
        if not section("Surfaces") or state.volume is None:
            return
        levels = state.levels
        value_range = state.value_range
        # Fixed columns: the value and its flag never push the remove button about.
        value_width = max(imgui.calc_text_size(level_text(v, value_range)).x for v in value_range)
        flag_width = max(imgui.calc_text_size(word).x for word in ("empty", "hidden"))
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
            # A drag field, not a slider: no grab covers its number.
            imgui.set_next_item_width(px(OPACITY_WIDTH))
            changed, opacity = imgui.drag_float("##opacity", level.opacity, 0.005, 0.0, 1.0, "%.2f",
                                                imgui.SliderFlags_.always_clamp)
            if changed:
                act(state, levels.set_opacity, i, opacity)
            tooltip("opacity: drag, or double-click to type (1 opaque, 0 invisible)")
            imgui.same_line()
            start = imgui.get_cursor_pos_x()
            imgui.text(level_text(level.value, value_range))
            imgui.same_line(start + value_width + imgui.get_style().item_spacing.x)
            start = imgui.get_cursor_pos_x()
            flag = self.flags.get(i)
            imgui.text_colored(FLAG_COLOR, flag or "")
            if flag:
                tooltip(self.flag_text(state, i))
            if len(levels) > 1:
                imgui.same_line(start + flag_width + imgui.get_style().item_spacing.x)
                if imgui.small_button("x"):
                    act(state, levels.remove, i)
                tooltip("remove this surface")
            imgui.pop_id()
        if len(levels) < MAX_LEVELS and imgui.button("Add surface"):
            low, high = value_range
            act(state, levels.add, min(state.iso + NEW_LEVEL_STEP * (high - low), high))
        self._color_by(state)

    def flag_text(self, state: ViewerState, index: int) -> str | None:
        """What the flag of level `index` means, in a line (its tooltip, and the status line's for the
        selected level); None where it has none."""
        level = state.levels[index]
        if self.flags.get(index) == "empty":
            return empty_level_hint(level.value, state.value_range, state.histogram)
        if self.flags.get(index) == "hidden":
            return (f"surface {index + 1} ({level_text(level.value, state.value_range)}) lies inside surface "
                    f"{self.hidden_in[index] + 1}, which is opaque: lower its opacity to see it")
        return None

    @staticmethod
    def flagged(state: ViewerState, scene) -> dict[int, str]:
        """Levels that show nothing: {index: "empty"} where the mesh has no triangle (as `scene` last made
        it, at full resolution), {index: "hidden"} where it lies inside a visible opaque level; none while the
        volume is ray cast alone (no surface is drawn)."""
        if not surfaces_drawn(state):
            return {}
        empty = []
        if scene is not None and scene.surface is not None:
            stats = scene.stats
            empty = [i for i in range(len(state.levels)) if (i != state.levels.selected or stats.preview_step == 1)
                     and stats.level_stats(i)[0] == 0]
        flags = {i: "hidden" for i in _enclosing(state, empty)}
        flags.update({i: "empty" for i in empty})
        return flags

    def _color_by(self, state: ViewerState) -> None:
        current = state.color_by.source if state.color_by is not None else "off"
        imgui.set_next_item_width(px(COMBO_WIDTH))
        choose(state, "colour by", current, ("off", *SOURCES),
               lambda choice: state.set_color_by(None if choice == "off" else choice))
        imgui.set_next_item_width(-imgui.calc_text_size("Colour by it").x - 2 * imgui.get_style().frame_padding.x
                                  - imgui.get_style().item_spacing.x)
        entered, self.volume_text = imgui.input_text_with_hint(
            "##second", "a volume of the same shape", self.volume_text, imgui.InputTextFlags_.enter_returns_true)
        imgui.same_line()
        if (imgui.button("Colour by it") or entered) and self.volume_text.strip():
            act(state, state.set_color_by, self.volume_text.strip())
        if state.color_by is None:
            return
        imgui.set_next_item_width(px(COMBO_WIDTH))
        choose(state, "colour map", state.color_by.colormap, COLORMAPS,
               lambda name: state.set_color_by(state.color_by.spec, name))
        _colorbar(state.color_by)


def _enclosing(state: ViewerState, empty) -> dict[int, int]:
    """{i: j}: level i lies inside the opaque level j, not one of the `empty` (model/hints.py)."""
    return enclosing_levels(list(state.levels), state.gradient_direction == "descent",
                            state.slices.clip is not None, empty)


def _colorbar(color_by) -> None:
    """The map as a horizontal bar, its end values under it."""
    left_top = imgui.get_cursor_screen_pos()
    width = imgui.get_content_region_avail().x
    draw = imgui.get_window_draw_list()
    lut = color_by.lut
    height = px(COLORBAR_HEIGHT)
    for k in range(COLORBAR_SEGMENTS):
        r, g, b = lut[min(k * len(lut) // COLORBAR_SEGMENTS, len(lut) - 1)]
        x0 = left_top.x + width * k / COLORBAR_SEGMENTS
        x1 = left_top.x + width * (k + 1) / COLORBAR_SEGMENTS
        draw.add_rect_filled(imgui.ImVec2(x0, left_top.y), imgui.ImVec2(x1 + 1, left_top.y + height),
                             imgui.get_color_u32(imgui.ImVec4(float(r), float(g), float(b), 1.0)))
    imgui.dummy(imgui.ImVec2(width, height))
    low, high = color_by.value_range
    start_x = imgui.get_cursor_pos_x()
    imgui.text(tick_label(low, low, high))
    for text, at in ((color_by.source, 0.5), (tick_label(high, low, high), 1.0)):
        imgui.same_line(start_x + max((width - imgui.calc_text_size(text).x) * at, 0.0))
        imgui.text(text)
