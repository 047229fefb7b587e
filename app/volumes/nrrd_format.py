"""NRRD (.nrrd, .nhdr with a detached data file) through pynrrd.

pynrrd's default Fortran index order gives data[x, y, z], so axis 0 is x as
isoscope wants. Spacing comes from "spacings" or the lengths of the "space
directions"; a 4-D file's time axis is the one whose kind is not spatial.
"""
from __future__ import annotations

import bz2
import io
import math
import os
from pathlib import Path

import numpy as np

from .errors import VolumeError
from .reading import Loaded, inflate_bounded, read_or_explain, reason, refuse_unless_regular
from .time_points import select_time
from .volume import Progress, refuse_if_too_big, report

_SPATIAL_KINDS = {"domain", "space"}


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
    spatial = [d for d in rows if np.all(np.isfinite(d))]  # a time axis has "none"
    if len(spatial) != 3:
        return None
    world = np.eye(4)
    world[:3, :3] = np.array(spatial).T * np.array(flip)[:, None]
    world[:3, 3] = np.asarray(origin, np.float64) * np.array(flip)
    return world, "LPS"


def nrrd_unit(path: Path, notes: list[str]) -> str | None:
    """The length unit the header's "space units" state for every spatial axis ("mm", "um", ...), or None where it
    states none; units that differ between the axes, or are no length unit known here, are taken as none, with a
    note (the samples still open; only measures depend on it)."""
    import nrrd

    from ..core.units import TAKEN_AS_MM, one_length_unit
    stated = [str(u) for u in nrrd.read_header(str(path)).get("space units") or [] if str(u).strip()]
    unit = one_length_unit(stated)
    if unit is not None or not stated:
        return unit
    notes.append(f"{path.name}: its space units {stated} are not one length unit isoscope knows; {TAKEN_AS_MM} "
                 "(write one unit such as \"mm\" or \"um\" for every axis)")
    return None


# The NRRD format's sample types, each spelling it allows, and their bytes per sample.
_TYPES = {**dict.fromkeys(("signed char", "int8", "int8_t", "uchar", "unsigned char", "uint8", "uint8_t"), 1),
          **dict.fromkeys(("short", "short int", "signed short", "signed short int", "int16", "int16_t", "ushort",
                           "unsigned short", "unsigned short int", "uint16", "uint16_t"), 2),
          **dict.fromkeys(("int", "signed int", "int32", "int32_t", "uint", "unsigned int", "uint32", "uint32_t",
                           "float"), 4),
          **dict.fromkeys(("longlong", "long long", "long long int", "signed long long", "signed long long int",
                           "int64", "int64_t", "ulonglong", "unsigned long long", "unsigned long long int",
                           "uint64", "uint64_t", "double"), 8)}
_COMPRESSED = {"gzip": "gzip", "gz": "gzip", "bzip2": "bzip2", "bz2": "bzip2"}
_LINE_LIMIT = 1 << 16  # a "line skip" line longer than this is not a text line
_TEXT_BYTES_PER_SAMPLE = 64  # a number written as text, with its separator, at its longest


def _data_file(path: Path, header: dict) -> tuple[Path, bool]:
    """(the file holding the samples, whether they follow a header in it)."""
    name = header.get("data file", header.get("datafile"))
    if name is None:
        return path, True
    if str(name).upper().startswith("LIST") or "%" in str(name) or len(str(name).split()) > 1:
        raise VolumeError(f"{path.name} spreads its samples over several data files, which isoscope does "
                          "not read; save the volume as one .nrrd")
    data_path = Path(name) if Path(name).is_absolute() else path.parent / name
    if not data_path.exists():
        raise VolumeError(f"{path.name} names the data file {name}, which does not exist; keep it beside the "
                          f"header or fix 'data file:'")
    refuse_unless_regular(data_path, f"{path.name}'s data file {name}")
    return data_path, False


def _read_data(path: Path, header: dict) -> np.ndarray:
    """The samples, read no further than the header's sizes imply: a compressed body may not inflate
    past them (a bomb), a data file is never read to an end the header does not need (a pipe, a
    huge file), and a gzip body is checked to its CRC. pynrrd then lays the bytes out (type,
    endianness, axis order) from a header whose data is those bytes, raw and in memory."""
    import nrrd
    encoding = str(header.get("encoding", "raw")).lower()
    count = math.prod(int(n) for n in header["sizes"])
    data_path, attached = _data_file(path, header)
    if encoding not in ("raw", *_COMPRESSED):  # text: pynrrd parses it, after a bound on the file's size
        if data_path.stat().st_size > _TEXT_BYTES_PER_SAMPLE * count + _LINE_LIMIT:
            raise VolumeError(f"{path.name}'s text data is {data_path.stat().st_size:,} bytes, far more than "
                              f"{count:,} numbers take; check its sizes or export it again")
        return nrrd.read(str(path))[0]
    needed = count * _TYPES[str(header["type"]).lower()]
    line_skip = int(header.get("line skip", header.get("lineskip", 0)))
    byte_skip = int(header.get("byte skip", header.get("byteskip", 0)))
    if line_skip < 0 or byte_skip < -1:
        raise VolumeError(f"{path.name}: line skip {line_skip} / byte skip {byte_skip} are not valid NRRD "
                          "(line skip >= 0, byte skip >= -1); fix the header")
    with open(data_path, "rb") as stream:
        if attached:  # the samples follow the header's blank line
            while stream.readline(_LINE_LIMIT).strip():
                pass
        for _ in range(line_skip):
            if not stream.readline(_LINE_LIMIT).endswith(b"\n"):
                raise VolumeError(f"{path.name}: its 'line skip: {line_skip}' passes the end of a text line; "
                                  "fix the header")
        if encoding in _COMPRESSED:
            decompressor = bz2.BZ2Decompressor() if _COMPRESSED[encoding] == "bzip2" else None
            # byte skip -1: the samples are the last bytes of the inflated stream, after a short preamble
            limit = needed + (max(byte_skip, 0) if byte_skip >= 0 else _LINE_LIMIT)
            body = inflate_bounded(stream, limit, path.name, decompressor)
            body = body[byte_skip:] if byte_skip >= 0 else body[-needed:]
        else:
            if byte_skip >= 0:
                stream.seek(byte_skip, os.SEEK_CUR)
            elif data_path.stat().st_size >= needed:  # -1: the samples are the file's last bytes
                stream.seek(-needed, os.SEEK_END)
            body = stream.read(needed + 1)
    if len(body) != needed:
        more = "more" if len(body) > needed else "fewer"
        raise VolumeError(f"{path.name} holds {more} sample bytes than its header's sizes "
                          f"({' x '.join(str(int(n)) for n in header['sizes'])}) imply: {needed:,}; export it again")
    raw = {key: value for key, value in header.items()
           if key not in ("data file", "datafile", "line skip", "lineskip", "byte skip", "byteskip")}
    raw["encoding"] = "raw"
    return nrrd.read_data(raw, io.BytesIO(body))


def load_nrrd(path: Path, time: int | None, progress: Progress | None = None) -> Loaded:
    """(data, spacing, notes) of an NRRD file's time point `time`; a header that is missing, damaged or of a type the
    format does not have is a VolumeError naming it."""
    import nrrd
    try:
        header = nrrd.read_header(str(path))
    except (nrrd.NRRDError, OSError, ValueError, UnicodeDecodeError, StopIteration) as exc:  # Stop: no lines
        raise VolumeError(f"{path.name} has no valid NRRD header ({reason(exc)}); check the file") from None
    missing = [field for field in ("type", "sizes", "encoding") if field not in header]
    if missing:
        raise VolumeError(f"{path.name}'s NRRD header has no {' or '.join(missing)} field (cut off or damaged); "
                          "export it again")
    if header.get("type") == "block":
        raise VolumeError(f"{path.name} holds NRRD 'block' samples, not numbers; save a numeric type")
    if str(header["type"]).lower() not in _TYPES:
        raise VolumeError(f"{path.name}'s NRRD type {header['type']!r} is not one of the format's sample types "
                          "(uchar, short, int, float, double, ...); fix the header")
    sizes = [int(s) for s in np.atleast_1d(header["sizes"])]
    if not sizes or min(sizes) < 1:
        raise VolumeError(f"{path.name}'s NRRD sizes ({' '.join(map(str, sizes))}) are not positive; fix the header")
    refuse_if_too_big(sizes, _TYPES[str(header["type"]).lower()], path.name)
    report(progress, 0.0, f"reading {path.name}")  # pynrrd reads in one call: no finer progress
    data = read_or_explain(path, lambda: _read_data(path, header), (nrrd.NRRDError,))
    notes: list[str] = []
    spatial_axes = list(range(data.ndim))
    if data.ndim == 4:
        kinds = [str(k).lower() for k in header.get("kinds", [])]
        time_axis = next((a for a, k in enumerate(kinds) if k not in _SPATIAL_KINDS), 3)
        data, notes = select_time(data, time_axis, time, path.name)
        spatial_axes.remove(time_axis)
    else:
        data, notes = select_time(data, 0, time, path.name)  # refuses --time on 3-D data
    return data, _spacing(header, spatial_axes) if len(spatial_axes) == 3 else None, notes
