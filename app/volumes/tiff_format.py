"""TIFF stacks (microscopy) through tifffile: the first series as (z, y, x), spacing from its metadata.

ImageJ hyperstacks give the z step as "spacing" and x/y by the XResolution/YResolution
tags (pixels per unit); OME-TIFF gives PhysicalSizeX/Y/Z.  A time axis is the frames
(--time N); colour channels are refused with the fix.
"""
from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np

from ..errors import InputError
from .errors import VolumeError
from .reading import library_messages, read_or_explain
from .time_points import select_time
from .volume import Progress, refuse_if_too_big, report

TIFF_SUFFIXES = (".tif", ".tiff")


def _resolution_spacing(page, tag: str) -> float | None:
    value = page.tags.get(tag)
    if value is None:
        return None
    numerator, denominator = value.value
    return denominator / numerator if numerator and numerator != denominator else None


def _spacing(tif, axes: str):
    """((z, y, x) from OME PhysicalSize* or ImageJ's spacing and resolution tags, or None if absent; the units
    they state: OME's PhysicalSize*Unit (the schema's default: micrometres), ImageJ's "unit")."""
    if tif.is_ome and tif.ome_metadata:
        pixels = re.search(r"<Pixels\b[^>]*>", tif.ome_metadata)
        sizes = {axis: re.search(rf'PhysicalSize{axis}="([0-9.eE+-]+)"', pixels.group(0)) if pixels else None
                 for axis in "ZYX"}
        if all(sizes.values()):
            units = [re.search(rf'PhysicalSize{axis}Unit="([^"]*)"', pixels.group(0)) for axis in "ZYX"]
            return (tuple(float(sizes[axis].group(1)) for axis in "ZYX"),
                    [unit.group(1) if unit else "µm" for unit in units])
    if tif.is_imagej and tif.imagej_metadata:
        page = tif.pages[0]
        z = tif.imagej_metadata.get("spacing")
        y, x = _resolution_spacing(page, "YResolution"), _resolution_spacing(page, "XResolution")
        if z and y and x:
            unit = str(tif.imagej_metadata.get("unit") or "").replace("\\u00B5", "µ").replace("\\u00b5", "µ")
            return (float(z), float(y), float(x)), ([unit] * 3 if unit and unit != "pixel" else [])
    return None, []


def _length_unit(path: Path, stated: list[str], notes: list[str]) -> str | None:
    """The one length unit of `stated` (core.units' name), or None with a note where they differ or are unknown."""
    from ..core.units import TAKEN_AS_MM, one_length_unit
    unit = one_length_unit(stated)
    if unit is not None or not stated:
        return unit
    notes.append(f"{path.name}: its voxel size units {sorted(set(stated))} are not one length unit isoscope knows; "
                 f"{TAKEN_AS_MM}")
    return None


def load_tiff(path: Path, time: int | None, progress: Progress | None = None):
    """(array (z, y, x), spacing or None, notes, the length unit its metadata states or None)."""
    import tifffile
    report(progress, 0.0, f"reading {path.name}")

    def read():
        """The first series' samples, its axes' letters and its spacing; a file with no image, or one whose tags claim
        more than memory allows, is refused before it is read."""
        with tifffile.TiffFile(path) as tif:
            if not tif.series:
                raise InputError("no image in it")
            series = tif.series[0]
            # The size the tags claim, refused before tifffile allocates it (8 pages of 46000^2 reached
            # the allocator); one time point of a series is what is kept, but the series is read whole.
            refuse_if_too_big(series.shape, series.dtype.itemsize, path.name)
            return series.asarray(), series.axes.upper(), _spacing(tif, series.axes.upper())
    notes: list[str] = []
    with library_messages(notes, "tifffile"):  # "invalid page offset" and the like: notes, not stderr
        # tifffile reports a damaged file as any of these (an "incompatible keyframe" is a RuntimeError)
        data, axes, (spacing, units) = read_or_explain(path, read, (tifffile.TiffFileError, RuntimeError, IndexError,
                                                           KeyError, TypeError, struct.error))
    keep = [a for a, n in zip(axes, data.shape) if n > 1 or a in "ZYX"]
    data = data.reshape([n for a, n in zip(axes, data.shape) if a in keep])
    axes = "".join(keep)
    if any(a in axes for a in "CS"):
        raise VolumeError(f"{path.name} holds colour channels (axes {axes}); save one channel as a grey "
                          "stack (ImageJ: Image > Color > Split Channels)")
    if "T" in axes:
        data, time_notes = select_time(data, axes.index("T"), time, path.name)
        axes = axes.replace("T", "")
    else:
        data, time_notes = select_time(data, 0, time, path.name)  # refuses --time on a 3-D stack
    notes += time_notes
    if axes != "ZYX" and data.ndim == 3:
        notes.append(f"{path.name}: axes {axes} read as z, y, x")
    return np.ascontiguousarray(data), spacing, notes, _length_unit(path, units, notes)
