"""The iso values on show: up to `MAX_LEVELS` levels of the one volume, each with its colour, opacity
and visibility, and the space key's sweep of the selected one.

The selected level is the one the slider, keys, histogram and animation move.  Every value stays
inside the volume's value range (`value_range`, set from the volume when it is shown): a value set
from outside is clamped, a level added outside it refused.  Refusals raise `ViewerError` and change
nothing.  No GL here: the GPU side (gfx/scene.py) keeps each level's mesh.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import ViewerError

MAX_LEVELS = 4
# Colours of added levels (the first level takes the style's front colour): far apart in hue.
PALETTE = ((0.95, 0.80, 0.45), (0.55, 0.85, 0.55), (0.85, 0.55, 0.85), (0.95, 0.55, 0.45))
ANIMATION_PERIOD_S = 6.0          # one sweep up and back down
ANIMATION_SPAN = (0.02, 0.98)     # fractions of the range; the very ends give empty surfaces


@dataclass(eq=False)   # compared by identity: the GPU side keys each level's mesh by the level itself
class Level:
    """One iso level: its value, its colour (None: the style's front colour), opacity 0..1 and whether it is drawn."""
    value: float
    color: tuple[float, float, float] | None = None   # None: the style's front colour
    opacity: float = 1.0
    visible: bool = True


class Levels:
    """The levels, the selected one, and the value range they live in."""

    def __init__(self, value_range: tuple[float, float] = (0.0, 1.0), value: float | None = None):
        self.animation = IsoAnimation()
        self.reset(value_range, value)

    def reset(self, value_range: tuple[float, float], value: float | None = None) -> None:
        """A new volume: one level at `value` (clamped; None: the middle of the range), selected."""
        low, high = float(value_range[0]), float(value_range[1])
        self.value_range = (low, high)
        self.items = [Level(self.clamp((low + high) / 2 if value is None else value))]
        self.selected = 0

    # --- reading -----------------------------------------------------------
    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self):
        return iter(self.items)

    def __getitem__(self, index: int) -> Level:
        return self.items[index]

    @property
    def current(self) -> Level:
        """The selected level."""
        return self.items[self.selected]

    @property
    def value(self) -> float:
        """The selected level's value: the iso value the slider shows."""
        return self.current.value

    def values(self) -> list[float]:
        """Every level's value, in order."""
        return [level.value for level in self.items]

    def clamp(self, value: float) -> float:
        """`value` moved into the value range."""
        low, high = self.value_range
        return min(max(float(value), low), high)

    def color(self, index: int, default: tuple[float, float, float]) -> tuple[float, float, float]:
        """Level `index`'s colour, or `default` (the style's front colour) where it has none of its own."""
        color = self[index].color
        return default if color is None else color

    # --- changing ----------------------------------------------------------
    def set_value(self, value: float) -> None:
        """Move the selected level to `value`, clamped to the value range."""
        self.current.value = self.clamp(value)

    def nudge(self, fraction_of_range: float) -> None:
        """Move the selected level by `fraction_of_range` of the value range (the = - + keys' steps), clamped."""
        low, high = self.value_range
        self.set_value(self.value + fraction_of_range * (high - low))

    def add(self, value: float) -> None:
        """A new level at `value`, selected (the slider now moves it)."""
        if len(self.items) >= MAX_LEVELS:
            raise ViewerError(f"at most {MAX_LEVELS} surfaces at once; remove one before adding another")
        low, high = self.value_range
        if not low <= float(value) <= high:
            raise ViewerError(f"level {float(value):g} is outside the value range {low:g} .. {high:g}; "
                              "pick a value inside it")
        self.items.append(Level(float(value), PALETTE[(len(self.items) - 1) % len(PALETTE)]))
        self._select(len(self.items) - 1)

    def remove(self, index: int) -> None:
        """Remove level `index`; the one after it (or the new last one) takes the slider if it was selected. The last
        level cannot be removed (ViewerError: hide it instead)."""
        self._check(index)
        if len(self.items) == 1:
            raise ViewerError("the last surface cannot be removed; hide it instead")
        self.items.pop(index)
        if index < self.selected:
            self.selected -= 1
        elif index == self.selected:   # the level after it (or the new last one) takes the slider
            self._select(min(index, len(self.items) - 1))

    def select(self, index: int) -> None:
        """The slider moves level `index` from now on."""
        self._check(index)
        if index != self.selected:
            self._select(index)

    def restore(self, items: list[Level], selected: Level) -> None:
        """Back to `items`, `selected` selected: the GPU side undoing a change it could not make."""
        self.items, self.selected = list(items), items.index(selected)

    def toggle_animation(self) -> None:
        """The space key: sweep the selected level up and down the range, or stop."""
        if self.animation.running:
            self.animation.running = False
        else:
            self.animation.start(self.value, self.value_range)

    def animate(self, dt_seconds: float) -> None:
        """The sweep `dt_seconds` further on, while it runs."""
        if self.animation.running:
            self.current.value = self.animation.advance(dt_seconds, self.value_range)

    def _select(self, index: int) -> None:
        self.selected = index
        self.animation.running = False

    def set_color(self, index: int, color) -> None:
        """Give level `index` its own RGB colour, three values 0..1; anything else is a ViewerError and the colour
        stays."""
        self._check(index)
        color = tuple(float(c) for c in color)
        if len(color) != 3 or not all(0.0 <= c <= 1.0 for c in color):
            raise ViewerError(f"colour {color} is not three values 0..1; pick an RGB colour")
        self.items[index].color = color

    def set_opacity(self, index: int, opacity: float) -> None:
        """Set level `index`'s opacity (1 opaque, 0 invisible); a value outside 0..1 is a ViewerError."""
        self._check(index)
        if not 0.0 <= float(opacity) <= 1.0:
            raise ViewerError(f"opacity {opacity:g} is outside 0..1; 1 is opaque, 0 invisible")
        self.items[index].opacity = float(opacity)

    def set_visible(self, index: int, visible: bool) -> None:
        """Draw level `index` or not; a hidden level keeps its value and looks."""
        self._check(index)
        self.items[index].visible = bool(visible)

    def _check(self, index: int) -> None:
        if not 0 <= index < len(self.items):
            raise ViewerError(f"there is no surface {index + 1}; there are {len(self.items)}")


class IsoAnimation:
    """The space key's sweep of the selected level up and down the range, eased at the ends."""

    def __init__(self):
        self.running = False
        self._phase = 0.0

    def start(self, value: float, value_range: tuple[float, float]) -> None:
        """Start the sweep at `value`'s place in `value_range`, so the surface does not jump when it begins."""
        # Start the sweep from the current value so the surface does not jump.
        low, high = value_range
        start, end = ANIMATION_SPAN
        fraction = ((value - low) / (high - low) - start) / (end - start) if high > low else 0.0
        self._phase = math.acos(1 - 2 * min(max(fraction, 0.0), 1.0)) / (2 * math.pi)
        self.running = True

    def advance(self, dt_seconds: float, value_range: tuple[float, float]) -> float:
        """The value `dt_seconds` further along the sweep."""
        self._phase = (self._phase + dt_seconds / ANIMATION_PERIOD_S) % 1.0
        low, high = value_range
        start, end = ANIMATION_SPAN
        sweep = (1 - math.cos(2 * math.pi * self._phase)) / 2  # 0 -> 1 -> 0, eased at the ends
        return low + (high - low) * (start + (end - start) * sweep)
