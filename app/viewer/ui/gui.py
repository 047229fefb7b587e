"""imgui, imported here once for every module of the viewer that draws with it, and what every panel
section does with it: `act` on the state (a refusal noted beside the control that caused it), `tooltip`
(beside the panel, never over the controls below), `section` (a header that folds, remembered), `px`
(a size in the panel's units, scaled with the monitor or the render).

imgui-bundle's native module calls back into Python while it starts; a Ctrl-C landing there
(one `render` in ten, interrupted in its first half-second) raises inside nanobind, which aborts
the process ("Critical nanobind error"). So the import runs with SIGINT and SIGTERM held off
(atomic.signals_deferred) and a Ctrl-C is acted on as it ends: exit 130, no core dump.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...io.atomic import signals_deferred
from ..model.errors import USER_ERRORS, one_line

with signals_deferred():
    from imgui_bundle import imgui

__all__ = ["act", "imgui", "px", "section", "tooltip"]

TOOLTIP_GAP = 6.0   # between the panel's right edge and a tooltip or refusal beside it (units)


@dataclass
class Refusal:
    """A change `act` refused: its one line (the state's `error`, the very string) and where the control
    that asked for it sits: `window`'s name, its top `y` and `height` in the window's scrolled content."""
    text: str
    window: str
    y: float
    height: float


_refusal: Refusal | None = None
_memory = None   # the laying-out panel's PanelSettings (model/settings.py): which sections are open
headers: dict[str, tuple] = {}   # this layout's section headers: title -> ((left, top), (right, bottom))


def act(state, change, *args) -> bool:
    """Make a change of the `ViewerState`; one it refuses (an exception) becomes the state's `error`, in
    one line, noted beside the control just drawn (`refusal`), and nothing changes.  Whether it was made."""
    global _refusal
    try:
        change(*args)
    except USER_ERRORS as exc:
        state.error = one_line(exc)
        _refusal = _where(state.error)
        return False
    state.error = None
    return True


def choose(state, label: str, current: str, choices, change) -> None:
    """A combo box `label` showing `current`, listing `choices` (strings); picking one makes the state
    change `change(choice)` through `act` (a refusal is noted at the combo box)."""
    if imgui.begin_combo(label, current):
        for choice in choices:
            if imgui.selectable(choice, choice == current)[0]:
                act(state, change, choice)
        imgui.end_combo()


def _where(text: str) -> Refusal | None:
    """The control last drawn, as a Refusal of `text`: a combo's choice is placed at its combo box (its
    popup opens just under it).  None outside a layout (no imgui context: a script acting on the state)."""
    if imgui.get_current_context() is None:
        return None
    window = imgui.internal.get_current_window_read()
    if window is None:
        return None
    top, bottom = imgui.get_item_rect_min().y, imgui.get_item_rect_max().y
    if window.flags & imgui.WindowFlags_.popup and window.parent_window is not None:
        bottom = window.pos.y
        top = bottom - imgui.get_frame_height()
        window = window.parent_window
    return Refusal(text, window.name, top - window.pos.y + window.scroll.y, bottom - top)


def refusal(state, window_name: str) -> Refusal | None:
    """The refusal to show beside a control of the window `window_name`: the state's error while it is the
    one line `act` noted there (any later error or success replaces it)."""
    if _refusal is not None and state.error is _refusal.text and _refusal.window == window_name:
        return _refusal
    return None


def px(units: float) -> float:
    """`units` of the panel's layout (written for a 1x screen) at the UI's scale (the style's font_scale_dpi,
    set from the monitor's content scale or the render's height)."""
    return units * imgui.get_style().font_scale_dpi


def tooltip(text: str) -> None:
    """`text` for the control just drawn, once the pointer rests on it: to the right of the panel at the
    control's height, so it covers no control below (imgui's own place, under the pointer, where the right
    has no room)."""
    if not imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip):
        return
    window = imgui.internal.get_current_window_read()
    display = imgui.get_io().display_size
    padding = imgui.get_style().window_padding
    width = imgui.calc_text_size(text).x + 2 * padding.x
    if window is not None:
        root = window.root_window
        x = root.pos.x + root.size.x + px(TOOLTIP_GAP)
        if x + width <= display.x:
            height = imgui.calc_text_size(text).y + 2 * padding.y
            y = min(imgui.get_item_rect_min().y, max(display.y - height, 0.0))
            imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_tooltip(text)


def remember_sections(memory) -> None:
    """The PanelSettings whose open sections `section` keeps (the panel sets it as it lays itself out)."""
    global _memory
    _memory = memory
    headers.clear()


def section(title: str, default_open: bool = True) -> bool:
    """A section's header, folding what follows; whether it is open.  Remembered across frames and, in the
    window, across runs (model/settings.py)."""
    memory = _memory
    if memory is None:
        flags = imgui.TreeNodeFlags_.default_open if default_open else 0
        is_open = imgui.collapsing_header(title, flags=flags)
    else:
        was_open = memory.is_open(title, default_open)
        imgui.set_next_item_open(was_open, imgui.Cond_.always)
        is_open = imgui.collapsing_header(title)
        if is_open != was_open:
            memory.set_open(title, is_open)
    headers[title] = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
    return is_open
