"""DVR's transfer function in the panel: a preset to start from, and its points drawn over the values'
histogram (x: value, y: opacity), dragged with the mouse.  Every change goes through the state
(`set_transfer`, `move_transfer_point`: model/raycast.py), which keeps the points in order and in range.
"""
from __future__ import annotations

from ..model.histogram import fraction_of, level_at
from ..model.raycast import PRESETS, preset_of
from ..model.state import ViewerState
from .gui import act, choose, imgui, px, tooltip

EDITOR_HEIGHT = 64.0   # units, as the level's histogram
GRAB_RADIUS = 7.0      # units: a press this near a point takes it
LINE_COLOUR = (0.45, 0.85, 1.0, 1.0)   # apart from the histogram's orange


class TransferEditor:
    """DVR's transfer function over the value histogram: a preset chosen, its points dragged with the mouse."""

    def __init__(self):
        self.box = None        # the editor's ((left, top), (right, bottom)) this frame, for tests and hints
        self.dragged: int | None = None   # the point under the mouse while the button is held

    def _plot(self) -> tuple[float, float, float, float]:
        """(left, top, width, height) where the points go: the box less a point's radius all round, so
        every point is whole inside the box that takes the mouse."""
        (left, top), (right, bottom) = self.box
        inset = px(GRAB_RADIUS)
        return left + inset, top + inset, max(right - left - 2 * inset, 1.0), max(bottom - top - 2 * inset, 1.0)

    def point_at(self, index: int, state: ViewerState) -> tuple[float, float]:
        """Where point `index` is drawn (screen pixels), in this frame's box."""
        left, top, width, height = self._plot()
        value, opacity = state.transfer[index]
        return left + fraction_of(value, state.value_range) * width, top + (1.0 - opacity) * height

    def point_under(self, x: float, y: float, state: ViewerState) -> tuple[float, float]:
        """The (value, opacity) at screen point (x, y) (outside the range: clamped by the state)."""
        left, top, width, height = self._plot()
        return level_at((x - left) / width, state.value_range), 1.0 - (y - top) / height

    def draw(self, state: ViewerState) -> None:
        """Lay out the preset choice and, with a transfer function and a histogram, its points; a drag moves the point
        under the mouse through `state`."""
        self.box = None
        current = "ramp" if state.transfer is None else preset_of(state.transfer, state.value_range) or "edited"
        choose(state, "transfer", current, ("ramp", *PRESETS),
               lambda choice: state.set_transfer(None if choice == "ramp" else choice))
        tooltip("DVR's opacity over the values: the window's ramp, or a preset whose points you drag below")
        if state.transfer is None or state.histogram is None:
            return
        top_left = imgui.get_cursor_screen_pos()
        size = imgui.ImVec2(imgui.get_content_region_avail().x, px(EDITOR_HEIGHT))
        self.box = ((top_left.x, top_left.y), (top_left.x + size.x, top_left.y + size.y))
        imgui.invisible_button("##transfer_points", size)   # first: of overlapping items it takes the mouse
        mouse = imgui.get_io().mouse_pos
        if imgui.is_item_activated():
            near = [(abs(mouse.x - x) + abs(mouse.y - y), i) for i, (x, y) in
                    ((i, self.point_at(i, state)) for i in range(len(state.transfer)))]
            distance, index = min(near)
            self.dragged = index if distance <= 2 * px(GRAB_RADIUS) else None
        if imgui.is_item_active() and self.dragged is not None:
            act(state, state.move_transfer_point, self.dragged, *self.point_under(mouse.x, mouse.y, state))
        elif not imgui.is_item_active():
            self.dragged = None
            tooltip("opacity (up) at each value (across), over the values' histogram: drag a point")
        imgui.set_cursor_screen_pos(top_left)
        imgui.plot_histogram("##transfer_histogram", state.histogram, graph_size=size)
        draw = imgui.get_window_draw_list()
        colour = imgui.get_color_u32(imgui.ImVec4(*LINE_COLOUR))
        points = [imgui.ImVec2(*self.point_at(i, state)) for i in range(len(state.transfer))]
        for a, b in zip(points, points[1:]):
            draw.add_line(a, b, colour, 2.0)
        for i, point in enumerate(points):
            draw.add_circle_filled(point, px(GRAB_RADIUS) * (1.3 if i == self.dragged else 1.0), colour)
