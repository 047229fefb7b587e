"""Length units a file may state for its axes, and how many millimetres each one is.

Measures (`isoscope measure`, the viewer's Measure section) report mm, mm^2 and mL; a file whose
lengths are in another unit (an OME-Zarr image in micrometres, a NIfTI in microns) is converted by
`mm_per_unit`.  The names are NGFF's (UDUNITS-2) and the ones NIfTI, NRRD and ImageJ write.

    >>> mm_per_unit("micrometer"), mm_per_unit(None), mm_per_unit("mm")
    (0.001, 1.0, 1.0)
    >>> length_unit_name("µm")
    'micrometer'
"""
from __future__ import annotations

# unit name (as a file states it, lower case) -> millimetres per unit; the first spelling of each is its name
_MM_PER_UNIT = {
    "millimeter": 1.0, "millimetre": 1.0, "mm": 1.0,
    "micrometer": 1e-3, "micrometre": 1e-3, "micron": 1e-3, "microns": 1e-3, "um": 1e-3, "µm": 1e-3, "μm": 1e-3,
    "nanometer": 1e-6, "nanometre": 1e-6, "nm": 1e-6,
    "angstrom": 1e-7, "å": 1e-7,
    "picometer": 1e-9, "pm": 1e-9,
    "centimeter": 10.0, "centimetre": 10.0, "cm": 10.0,
    "decimeter": 100.0, "dm": 100.0,
    "meter": 1e3, "metre": 1e3, "m": 1e3,
    "kilometer": 1e6, "km": 1e6,
    "inch": 25.4, "foot": 304.8,
}
_CANONICAL = {"millimetre": "millimeter", "mm": "millimeter", "micrometre": "micrometer", "um": "micrometer",
              "µm": "micrometer", "microns": "micron", "μm": "micrometer", "nanometre": "nanometer", "nm": "nanometer",
              "å": "angstrom", "pm": "picometer", "centimetre": "centimeter", "cm": "centimeter",
              "dm": "decimeter", "metre": "meter", "m": "meter", "km": "kilometer"}

_PLURALS = {"inches": "inch", "feet": "foot"}

# How a loader's note ends when a file states units it cannot use (mixed, or not lengths): measure repeats it.
TAKEN_AS_MM = "lengths are taken as millimetres"


def length_unit_name(text) -> str | None:
    """The unit `text` names (its NGFF spelling; "micron" stays "micron"), or None when it is no length unit known
    here (a time unit, "unknown", "pixel", not a string).  Plurals as free-text headers write them
    ("micrometers", "millimetres", "inches", "feet") name their unit.

    >>> length_unit_name("Micrometers"), length_unit_name("inches"), length_unit_name("pixels")
    ('micrometer', 'inch', None)
    """
    if not isinstance(text, str):
        return None
    key = text.strip().lower()
    if key not in _MM_PER_UNIT:
        key = _PLURALS.get(key) or (key[:-1] if key.endswith("s") and key[:-1] in _MM_PER_UNIT else key)
    if key not in _MM_PER_UNIT or len(key) <= 2 and text.strip().lower() != key:   # "ms" is no plural of "m"
        return None
    return _CANONICAL.get(key, key)


def one_length_unit(stated) -> str | None:
    """The one length unit every entry of `stated` (a file's units, one per axis) names, or None where they name
    different units or one not known here (each loader then notes that its lengths are TAKEN_AS_MM).

    >>> one_length_unit(["um", "micrometer", "µm"]), one_length_unit(["um", "mm"]), one_length_unit(["um", "s"])
    ('micrometer', None, None)
    """
    names = {length_unit_name(u) for u in stated}
    return names.pop() if len(names) == 1 and None not in names else None


def mm_per_unit(unit: str | None) -> float:
    """Millimetres per `unit` (1 for None: a file that states no unit is taken as millimetres)."""
    if unit is None:
        return 1.0
    return _MM_PER_UNIT[unit.strip().lower()]
