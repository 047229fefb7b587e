"""The one schema of a scene file: every field's type and range, checked as a whole before anything of the
scene is put on show, so that a hand-edited or hostile scene is refused in one line naming the field
(`camera.distance 1e+308 must be ...`), never a traceback half-way through applying it.

Numbers a user also gives on the command line go through their `core.numbers` spec (the same range as
`--smooth`, `--size`, `--elevation`); the rest are typed here.  Unknown keys are named, not ignored: a
misspelt "opactiy" would otherwise silently do nothing.  `open_options` takes only the command's own
volume flags.  No GL, no files: `check_scene(dict) -> dict` (defaults filled in) or SceneError.
"""
from __future__ import annotations

import math
from dataclasses import fields

from ...core.numbers import (
    AZIMUTH,
    CAMERA_DISTANCE,
    ELEVATION,
    FEATURE_ANGLE,
    IMAGE_SIDE,
    OPACITY,
    SMOOTH,
    Number,
)
from ...core.opener import shown
from ...errors import InputError
from ...options import CELLS, TOPOLOGIES
from .errors import ViewerError
from .levels import MAX_LEVELS
from .raycast import MAX_TRANSFER_POINTS, RAYCAST_MODES
from .style import SurfaceStyle

MAX_TEXT = 4096            # a path, a colour map's name: longer is not one
MAX_LAYERS = 65_536        # a label's look per label: as many as a label table may list
MAX_INDEX = 1 << 31


class SceneError(ViewerError):
    """A scene file that cannot be read or put on show; the message is one line."""


class _Bad(InputError):
    """A field's problem, raised with its place in the scene and turned into one SceneError line."""


class Field:
    """One field's type in the schema: `check` takes a value from the JSON and returns it checked, and `words` says what
    it must be."""

    def check(self, value, where: str):
        """`value` checked (and converted where the scene needs another type), or a refusal naming `where`, the field's
        place in the scene (`camera.distance`)."""
        raise NotImplementedError

    def words(self) -> str:
        """What a value must be, as the refusal says it ("true or false")."""
        raise NotImplementedError


class Num(Field):
    """A number with a range, through its `core.numbers` spec: the same range and words as the command line's flag."""

    def __init__(self, spec: Number):
        self.spec = spec

    def check(self, value, where):
        """`value` as its spec checks it; the spec's refusal, naming `where`."""
        try:
            return self.spec.check(value, where)
        except InputError as exc:
            raise _Bad(str(exc)) from None

    def words(self):
        """The spec's range in words."""
        return self.spec.range_words()


def whole(low: int, high: int, what: str) -> Num:
    """A whole number from `low` to `high`, called `what` in its refusals."""
    return Num(Number(what, what, True, low, high, str(low)))


class Real(Field):
    """Any finite number (a level: the volume decides its range)."""

    def check(self, value, where):
        """`value` as a float, if it is a finite number (not a bool)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise _Bad(f"{where} {_brief(value)} must be a finite number")
        return float(value)

    def words(self):
        """Its words: "a finite number"."""
        return "a finite number"


class Flag(Field):
    """A JSON true or false."""

    def check(self, value, where):
        """`value`, if it is a bool."""
        if not isinstance(value, bool):
            raise _Bad(f"{where} {_brief(value)} must be true or false")
        return value

    def words(self):
        """Its words: "true or false"."""
        return "true or false"


class Text(Field):
    """A non-empty string of at most `MAX_TEXT` characters, one of `choices` where there are some."""

    def __init__(self, choices: tuple[str, ...] | None = None):
        self.choices = choices

    def check(self, value, where):
        """`value`, if it is such a string (and one of the choices)."""
        if not isinstance(value, str) or not value or len(value) > MAX_TEXT:
            raise _Bad(f"{where} {_brief(value)} must be {self.words()}")
        if self.choices is not None and value not in self.choices:
            raise _Bad(f"{where} {_brief(value)} must be {self.words()}")
        return value

    def words(self):
        """The choices, or "a non-empty string"."""
        return "one of " + ", ".join(repr(c) for c in self.choices) if self.choices else "a non-empty string"


class Maybe(Field):
    """null, or the `inner` field."""

    def __init__(self, inner: Field):
        self.inner = inner

    def check(self, value, where):
        """None for null, else `value` as the inner field checks it."""
        return None if value is None else self.inner.check(value, where)

    def words(self):
        """Its words: "null or " and the inner field's."""
        return f"null or {self.inner.words()}"


class Either(Field):
    """The first of several fields that takes the value."""

    def __init__(self, *choices: Field):
        self.choices = choices

    def check(self, value, where):
        """`value` as the first choice that takes it checks it; a refusal naming every choice when none does."""
        for choice in self.choices:
            try:
                return choice.check(value, where)
            except _Bad:
                continue
        raise _Bad(f"{where} {_brief(value)} must be " + " or ".join(c.words() for c in self.choices))

    def words(self):
        """The choices' words, joined by "or"."""
        return " or ".join(c.words() for c in self.choices)


class Seq(Field):
    """A list of `item`s, `low` to `high` of them (a fixed length where they are equal)."""

    def __init__(self, item: Field, low: int, high: int):
        self.item, self.low, self.high = item, low, high

    def check(self, value, where):
        """`value` as a list of checked items, if it is a list of the allowed length; an item's refusal names its index.
        """
        if not isinstance(value, list) or not self.low <= len(value) <= self.high:
            raise _Bad(f"{where} {_brief(value)} must be {self.words()}")
        return [self.item.check(item, f"{where}[{i}]") for i, item in enumerate(value)]

    def words(self):
        """Its words: "a list of N (...)", its length and its items' words."""
        count = f"{self.low}" if self.low == self.high else f"{self.low} to {self.high:,}"
        return f"a list of {count} ({self.item.words()})"


class Obj(Field):
    """A JSON object with these keys (`required` must be there; the rest take `defaults` or are left out)."""

    def __init__(self, keys: dict[str, Field], required: tuple[str, ...] = ()):
        self.keys, self.required = keys, required

    def check(self, value, where):
        """`value` as a dict of checked fields, if it is an object with no unknown key and every required one; a refusal
        names the first unknown or missing key."""
        if not isinstance(value, dict):
            raise _Bad(f"{where or 'the scene'} {_brief(value)} must be an object {{...}}")
        unknown = [key for key in value if key not in self.keys]
        if unknown:
            raise _Bad(f"{where or 'the scene'} has an unknown key {shown(repr(unknown[0]))[:80]} (it takes "
                       f"{', '.join(self.keys)})")
        missing = [key for key in self.required if key not in value]
        if missing:
            raise _Bad(f"{_join(where, missing[0])} is missing")
        return {key: self.keys[key].check(item, _join(where, key)) for key, item in value.items()}

    def words(self):
        """Its words: "an object {...}"."""
        return "an object {...}"


def _join(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _brief(value) -> str:
    if isinstance(value, (dict, list)):
        return "{...}" if isinstance(value, dict) else "[...]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    text = shown(repr(value) if isinstance(value, str) else str(value))
    return text if len(text) <= 40 else text[:37] + "..."


UNIT = Num(Number("color", "a colour component", False, 0, 1, "0.5"))
COLOR = Seq(UNIT, 3, 3)   # [r, g, b], each 0..1
POSITIVE = Num(Number("spacing", "a length", False, 0, 1e9, "1.0", above_low=True))

OPEN_OPTIONS = Obj({   # the command's own volume flags (cli/volume_options.py), as open_volume takes them
    "dims": Seq(whole(1, 1 << 20, "samples"), 3, 3),
    "dtype": Text(("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")),
    "endian": Text(("little", "big")),
    "spacing": Seq(POSITIVE, 3, 3),
    "time": whole(0, MAX_INDEX, "a time point (from 0)"),
    "series": Either(whole(0, MAX_INDEX, "a series number"), Text()),
    "resolution": whole(2, 2048, "samples"),
})

SCENE = Obj({
    "format": Text(),
    "version": whole(0, 1 << 16, "a version number"),
    "volume": Obj({"source": Text(), "open_options": Maybe(OPEN_OPTIONS),
                   "gradient_direction": Maybe(Text(("descent", "ascent")))}, required=("source",)),
    "levels": Seq(Obj({"value": Real(), "color": Maybe(COLOR), "opacity": Num(OPACITY), "visible": Flag()},
                      required=("value",)), 1, MAX_LEVELS),
    "selected": whole(0, MAX_LEVELS - 1, "a level's place (from 0)"),
    "mesh": Obj({"cells": Text(CELLS), "smooth": Num(SMOOTH), "sharp": Maybe(Num(FEATURE_ANGLE)),
                 "closed": Flag(), "topology": Text(TOPOLOGIES)}),
    "labels": Either(Flag(), Obj({"names": Maybe(Text()),
                                  "layers": Seq(Obj({"label": whole(-MAX_INDEX, MAX_INDEX, "a label"),
                                                     "visible": Flag(), "opacity": Num(OPACITY)},
                                                    required=("label",)), 0, MAX_LAYERS)})),
    "color_by": Maybe(Obj({"source": Text(), "colormap": Maybe(Text())}, required=("source",))),
    "camera": Obj({"azimuth": Num(AZIMUTH), "elevation": Num(ELEVATION), "distance": Num(CAMERA_DISTANCE),
                   "target": Seq(Num(Number("target", "a coordinate", False, -1e9, 1e9, "0")), 3, 3)},
                  required=("azimuth", "elevation", "distance", "target")),
    "size": Seq(Num(IMAGE_SIDE), 2, 2),
    "slices": Obj({"shown": Seq(Flag(), 3, 3), "index": Seq(whole(0, MAX_INDEX, "a slice index"), 3, 3),
                   "active": whole(0, 2, "an axis"), "window": Maybe(Num(Number("window", "a width", False, 0, 1e300,
                                                                                "400", above_low=True))),
                   "centre": Maybe(Real()), "colormap": Maybe(Text()), "inset": Flag(),
                   "clip": Maybe(Obj({"axis": whole(0, 2, "an axis"), "position": Real(), "hide_above": Flag()},
                                     required=("axis", "position")))}),
    "style": Obj({item.name: COLOR if isinstance(item.default, tuple) else Flag()   # SurfaceStyle's own fields
                  for item in fields(SurfaceStyle)}),
    "raycast": Maybe(Text(RAYCAST_MODES)),
    "with_surfaces": Flag(),
    "transfer": Maybe(Seq(Seq(Real(), 2, 2), 2, MAX_TRANSFER_POINTS)),
}, required=("format", "version", "volume", "levels", "camera"))


def check_scene(scene, name: str) -> dict:
    """`scene` (parsed JSON) checked against SCENE, as a new dict; SceneError in one line naming the scene
    file `name` and the first field that is wrong."""
    try:
        checked = SCENE.check(scene, "")
    except _Bad as exc:
        raise SceneError(f"{name}: {exc}; fix that field or save the scene again") from None
    if "selected" in checked and checked["selected"] >= len(checked["levels"]):
        raise SceneError(f"{name}: selected {checked['selected']} names no level (the scene has "
                         f"{len(checked['levels'])}); fix that field or save the scene again")
    return checked
