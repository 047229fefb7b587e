"""How the scene looks: what the panel's toggles and colour pickers edit, and the renderer reads."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass
class SurfaceStyle:
    """How the surface looks: what the panel's toggles and colour pickers edit."""
    front_color: tuple[float, float, float] = (0.55, 0.70, 0.90)
    back_color: tuple[float, float, float] = (0.90, 0.45, 0.25)   # distinct, so holes/inside-out show
    background: tuple[float, float, float] = (0.11, 0.12, 0.14)
    box_color: tuple[float, float, float] = (0.65, 0.65, 0.65)
    lighting: bool = True
    wireframe: bool = False
    show_box: bool = True
    transparent_background: bool = False   # screenshots: background alpha 0 (RGBA PNG)
