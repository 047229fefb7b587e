"""imgui, imported here once for every module of the viewer that draws with it, and what every panel
section does with the state: `act` on it, showing a refusal in one line.

imgui-bundle's native module calls back into Python while it starts; a Ctrl-C landing there
(one `render` in ten, interrupted in its first half-second) raises inside nanobind, which aborts
the process ("Critical nanobind error"). So the import runs with SIGINT and SIGTERM held off
(atomic.signals_deferred) and a Ctrl-C is acted on as it ends: exit 130, no core dump.
"""
from __future__ import annotations

from ...io.atomic import signals_deferred
from ..model.errors import USER_ERRORS, one_line

with signals_deferred():
    from imgui_bundle import imgui

__all__ = ["act", "imgui", "tooltip"]


def act(state, change, *args) -> bool:
    """Make a change of the `ViewerState`; one it refuses (an exception) is shown in the panel, in one
    line, and nothing changes.  Whether it was made."""
    try:
        change(*args)
    except USER_ERRORS as exc:
        state.error = one_line(exc)
        return False
    state.error = None
    return True


def tooltip(text: str) -> None:
    if imgui.is_item_hovered():
        imgui.set_tooltip(text)
