"""imgui, imported here once for every module of the viewer that draws with it.

imgui-bundle's native module calls back into Python while it starts; a Ctrl-C landing there
(one `render` in ten, interrupted in its first half-second) raises inside nanobind, which aborts
the process ("Critical nanobind error"). So the import runs with SIGINT and SIGTERM held off
(atomic.signals_deferred) and a Ctrl-C is acted on as it ends: exit 130, no core dump.
"""
from __future__ import annotations

from ...io.atomic import signals_deferred

with signals_deferred():
    from imgui_bundle import imgui

__all__ = ["imgui"]
