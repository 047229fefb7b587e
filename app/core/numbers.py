"""One spec for every number a user gives: its type and its range, checked in one line before any work starts,
in the same words on the command line (`--smooth`), in a scene (`mesh.smooth`) and in Python (`smooth=`).

A number outside its range is refused, never clamped: a smoothing of 10^9 iterations would run for days, a
movie of 10^7 frames would fill the disk, an image of 0x0 pixels divides by zero, and each would do so
after minutes of work.  A spec says what the number is for and gives an example, so the refusal names the fix.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class Number:
    """A number a user gives: `what` it counts or measures, whole or not, in [low, high] (`low` excluded where
    `above_low`), with an `example` for the refusal's fix."""
    flag: str                 # its command-line flag, how the help and the refusals name it by default
    what: str                 # "iterations", "frames per second"
    whole: bool
    low: float
    high: float
    example: str
    above_low: bool = False   # low itself is refused (0 < fps)

    def check(self, value, said: str | None = None):
        """`value` as an int (whole) or a float, or InputError naming `said` (default: the flag) and the range.
        bool is refused (True is not 1 iteration), as are NaN, infinities and strings."""
        said = said or self.flag
        number = self._number(value)
        if number is None or not self._within(number):
            raise InputError(f"{said} {_shown(value)} must be {self.range_words()} (e.g. {self.example})")
        return int(number) if self.whole else float(number)

    def parse(self, text: str, said: str | None = None):
        """The number written in `text` (a command-line word), checked as `check` does."""
        try:
            value = int(text) if self.whole else float(text)
        except (TypeError, ValueError):
            try:   # "5.0" iterations is 5; "1e3" too
                value = float(text)
            except (TypeError, ValueError):
                raise InputError(f"{said or self.flag} {text!r} is not a number; it must be "
                                 f"{self.range_words()} (e.g. {self.example})") from None
        return self.check(value, said)

    def argument(self, flag: str | None = None):
        """An argparse `type=` for this number (given as `flag`, default its own): the refusal as argparse's
        one line (exit 2)."""
        import argparse

        def parse(text: str):
            try:
                return self.parse(text, flag)
            except InputError as exc:
                raise argparse.ArgumentTypeError(str(exc)) from None
        parse.__name__ = (flag or self.flag).lstrip("-").replace("-", "_")
        return parse

    def range_words(self) -> str:
        """What the number must be, in the words of its refusals: "a whole number of pixels, 16 to 16,384"."""
        named = self.what.startswith(("a ", "an "))   # "an axis": already says what it is
        kind = "a whole number of " + self.what if self.whole and not named else self.what
        low = f"{self.low:,}" if self.whole else f"{self.low:g}"
        high = f"{self.high:,}" if self.whole else f"{self.high:g}"
        if self.above_low:
            return f"{kind}, more than {low} and at most {high}"
        return f"{kind}, {low} to {high}"

    def _number(self, value):
        if isinstance(value, bool) or isinstance(value, str) or value is None:
            return None
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            return None
        if not math.isfinite(number) or (self.whole and not number.is_integer()):
            return None
        return number

    def _within(self, number: float) -> bool:
        return (self.low < number if self.above_low else self.low <= number) and number <= self.high


def _shown(value) -> str:
    text = repr(value) if isinstance(value, str) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


# Smoothing: each iteration is a pass over the mesh (~0.1 s on a million triangles); past a few hundred the
# surface no longer changes, as its vertices sit on the level set.
SMOOTH = Number("--smooth", "iterations", True, 0, 500, "5")
FPS = Number("--fps", "frames per second", False, 0, 240, "24", above_low=True)
FRAMES = Number("--frames", "frames", True, 1, 10_000, "60")
WINDOW_FRAMES = Number("--frames", "frames", True, 1, 10**9, "100")   # the window quits after N (scripts)
IMAGE_SIDE = Number("--size", "pixels", True, 16, 16384, "800x600")
MAX_LABELS = Number("--max-labels", "labels", True, 1, 65_535, "255")
AZIMUTH = Number("--azimuth", "degrees", False, -36_000, 36_000, "-60")
ELEVATION = Number("--elevation", "degrees", False, -90, 90, "25")
OPACITY = Number("--opacity", "an opacity", False, 0, 1, "0.5")
FEATURE_ANGLE = Number("--sharp", "degrees between normals", False, 0, 180, "30", above_low=True)
# A camera's distance from its target, in the scene's world units (millimetres for a scan): far enough for
# a 10-metre scan, finite enough that a view matrix stays representable.
CAMERA_DISTANCE = Number("camera.distance", "world units", False, 0, 1e7, "300", above_low=True)


def image_size(value, said: str = "size") -> tuple[int, int]:
    """(width, height) from a pair of numbers or a "WIDTHxHEIGHT" string, each side in IMAGE_SIDE's range;
    InputError in one line otherwise (a 0x0 or negative image, a word)."""
    if isinstance(value, str):
        parts = value.lower().replace(" ", "").split("x")
        if len(parts) != 2:
            raise InputError(f"{said} {value!r} is not WIDTHxHEIGHT, e.g. 800x600")
        width, height = (IMAGE_SIDE.parse(part, f"{said} {value!r}:") for part in parts)
        return width, height
    try:
        pair = list(value)
    except TypeError:
        pair = []
    if len(pair) != 2:
        raise InputError(f"{said} {_shown(value)} is not (width, height), e.g. (800, 600)")
    width, height = (IMAGE_SIDE.check(side, f"{said} {_shown(tuple(pair))}: a side of") for side in pair)
    return width, height
