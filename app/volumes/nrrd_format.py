"""NRRD (.nrrd, .nhdr with a detached data file) through pynrrd.

pynrrd's default Fortran index order gives data[x, y, z], so axis 0 is x as
isoscope wants. Spacing comes from "spacings" or the lengths of the "space
directions"; a 4-D file's frame axis is the one whose kind is not spatial.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import VolumeError
from .frames import select_frame
from .reading import Loaded, read_or_explain, reason
from .volume import Progress, refuse_if_too_big, report

_SPATIAL_KINDS = {"domain", "space"}


def _itemsize(type_name: str) -> int:
    """Bytes per sample from an NRRD "type" name; only for the size check before reading."""
    name = type_name.lower()
    if "char" in name or name.endswith(("int8", "int8_t")):
        return 1
    if "short" in name or "16" in name:
        return 2
    if "long" in name or "64" in name or name == "double":
        return 8
    return 4


def _spacing(header: dict, spatial_axes: list[int]):
    if "spacings" in header:
        values = [float(header["spacings"][a]) for a in spatial_axes]
    elif header.get("space directions") is not None:
        values = [float(np.linalg.norm(header["space directions"][a])) for a in spatial_axes]
    else:
        return None
    return tuple(values) if all(np.isfinite(v) and v > 0 for v in values) else None


_TO_LPS = {"left-posterior-superior": (1, 1, 1), "lps": (1, 1, 1),
           "right-anterior-superior": (-1, -1, 1), "ras": (-1, -1, 1),
           "left-anterior-superior": (1, -1, 1), "las": (1, -1, 1)}


def nrrd_world(path: Path):
    """(4x4 array index -> LPS millimetres, "LPS") from "space directions" and "space origin",
    or None when the header has no anatomical space (then index x spacing is all there is)."""
    import nrrd
    header = nrrd.read_header(str(path))
    flip = _TO_LPS.get(str(header.get("space", "")).lower())
    directions, origin = header.get("space directions"), header.get("space origin")
    if flip is None or directions is None or origin is None:
        return None
    rows = [np.asarray(d, np.float64) for d in directions]
    spatial = [d for d in rows if np.all(np.isfinite(d))]  # a frame axis has "none"
    if len(spatial) != 3:
        return None
    world = np.eye(4)
    world[:3, :3] = np.array(spatial).T * np.array(flip)[:, None]
    world[:3, 3] = np.asarray(origin, np.float64) * np.array(flip)
    return world, "LPS"


def load_nrrd(path: Path, frame: int | None, progress: Progress | None = None) -> Loaded:
    import nrrd
    try:
        header = nrrd.read_header(str(path))
    except (nrrd.NRRDError, OSError, ValueError, UnicodeDecodeError) as exc:
        raise VolumeError(f"{path.name} has no valid NRRD header ({reason(exc)}); check the file") from None
    if header.get("type") == "block":
        raise VolumeError(f"{path.name} holds NRRD 'block' samples, not numbers; save a numeric type")
    refuse_if_too_big([int(s) for s in header.get("sizes", [])],
                      _itemsize(str(header.get("type", "double"))), path.name)
    report(progress, 0.0, f"reading {path.name}")  # pynrrd reads in one call: no finer progress
    data, header = read_or_explain(path, lambda: nrrd.read(str(path)), (nrrd.NRRDError,))
    notes: list[str] = []
    spatial_axes = list(range(data.ndim))
    if data.ndim == 4:
        kinds = [str(k).lower() for k in header.get("kinds", [])]
        frame_axis = next((a for a, k in enumerate(kinds) if k not in _SPATIAL_KINDS), 3)
        data, notes = select_frame(data, frame_axis, frame, path.name)
        spatial_axes.remove(frame_axis)
    else:
        data, notes = select_frame(data, 0, frame, path.name)  # refuses --frame on 3-D data
    return data, _spacing(header, spatial_axes) if len(spatial_axes) == 3 else None, notes
