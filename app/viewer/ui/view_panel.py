"""The panel's View section: the six anatomical view directions (issue 26).

Plugged into `Panel.draw` (panel.py); its keys reach the window through `keys()`."""
from __future__ import annotations

from ..model.state import ViewerState


class ViewSection:
    def draw(self, state: ViewerState, camera) -> None:
        """Lay the section out (nothing yet)."""

    def keys(self, camera) -> dict:
        """Characters this section answers in the window (as window.py's `_on_char` table)."""
        return {}
