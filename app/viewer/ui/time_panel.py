"""The panel's Time section: a series' time slider and play button (issue 27).

Plugged into `Panel.draw` (panel.py); its keys reach the window through `keys()`."""
from __future__ import annotations

from ..model.state import ViewerState


class TimeSection:
    def draw(self, state: ViewerState, camera) -> None:
        """Lay the section out (nothing yet)."""

    def keys(self, camera) -> dict:
        """Characters this section answers in the window (as window.py's `_on_char` table)."""
        return {}
