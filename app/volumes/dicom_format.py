"""A DICOM series from a folder, with pydicom: slices sorted along their normal, rescaled, spaced.

The folder's files are read header-first and grouped by SeriesInstanceUID; with more
than one series, `series` picks one (a number from the listing, or the UID).  Slices
are sorted by ImagePositionPatient along the slice normal (the cross product of the
ImageOrientationPatient directions), which is right for any orientation and either
slice direction; their positions give the slice spacing, and PixelSpacing the rest.
RescaleSlope and RescaleIntercept are applied (CT comes out in Hounsfield units).
The array's axes are (slice, row, column), as the slices are stored.

A temporal series (cardiac cine, perfusion, fMRI: several acquisitions of the same slices in one
series) is a series of time points: where slice positions repeat, the files are grouped by
TemporalPositionIdentifier, else AcquisitionNumber, else TriggerTime (the first that gives every
position once per group), in the order of that number; `time` picks one (default 0) and only its
slices' pixels are read.  The folder's headers are kept (for the folder as it is) so that reading the
next time point does not read them all again.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import VolumeError
from .reading import library_messages
from .time_points import refuse_time, time_index, time_note
from .volume import Progress, refuse_if_too_big, report, shape_text

MAX_FILES = 20_000
GAP_TOLERANCE = 0.01  # of the slice spacing: how far apart positions may differ from even steps
TIME_KEYWORDS = ("TemporalPositionIdentifier", "AcquisitionNumber", "TriggerTime")
_headers_kept: dict = {}   # the last folder read: (folder, its state) -> its series' headers


def _read_header(path: Path):
    import pydicom
    from pydicom.errors import InvalidDicomError
    try:
        return pydicom.dcmread(path, stop_before_pixels=True)
    except (InvalidDicomError, OSError, EOFError, ValueError, TypeError, AttributeError):
        return None  # not DICOM (a DICOMDIR's neighbours, notes, thumbnails): skipped


def _series_files(folder: Path, progress: Progress | None):
    """SeriesInstanceUID -> [(path, header)] of every image in the folder (and below); the last folder's
    headers are kept while its files (names, sizes, times) stay as they were."""
    paths = sorted(p for p in folder.rglob("*") if p.is_file())
    state = (str(folder.resolve()), tuple((str(p), p.stat().st_size, p.stat().st_mtime_ns) for p in paths))
    if state in _headers_kept:
        return _headers_kept[state]
    series = _read_series_files(folder, paths, progress)
    _headers_kept.clear()
    _headers_kept[state] = series
    return series


def _read_series_files(folder: Path, paths: list, progress: Progress | None):
    if len(paths) > MAX_FILES:
        raise VolumeError(f"{folder.name} holds {len(paths)} files, more than {MAX_FILES}; "
                          "point isoscope at the series' own folder")
    series: dict[str, list] = {}
    for number, path in enumerate(paths, 1):
        header = _read_header(path)
        if header is not None and "Rows" in header:  # an image, not a report or a DICOMDIR
            series.setdefault(str(header.get("SeriesInstanceUID", "")), []).append((path, header))
        if number % 50 == 0:
            report(progress, 0.3 * number / len(paths), f"reading DICOM headers in {folder.name}")
    if not series:
        raise VolumeError(f"{folder.name} holds no DICOM images; point isoscope at a folder of .dcm files")
    return series


def _pick_series(folder: Path, series: dict[str, list], wanted: str | None):
    listing = sorted(series.items(), key=lambda item: (str(item[1][0][1].get("SeriesNumber", "")), item[0]))
    if wanted is None:
        if len(listing) == 1:
            return listing[0][1]
        rows = "; ".join(f"{i}: {uid} ({_describe(files)})" for i, (uid, files) in enumerate(listing, 1))
        raise VolumeError(f"{folder.name} holds {len(listing)} DICOM series ({rows}); pick one with "
                          f"--series N or --series UID")
    for i, (uid, files) in enumerate(listing, 1):
        if wanted in (str(i), uid):
            return files
    raise VolumeError(f"{folder.name} has no series {wanted!r}; it has "
                      f"{', '.join(f'{i}: {uid}' for i, (uid, _) in enumerate(listing, 1))}")


def _describe(files) -> str:
    header = files[0][1]
    text = " ".join(str(header.get(key, "")).strip() for key in ("Modality", "SeriesDescription")).strip()
    return f"{text + ', ' if text else ''}{len(files)} slices"


def _image_size(folder: Path, path: Path, header) -> tuple[int, int]:
    """(Rows, Columns) of one slice's header, refusing what is no grey image."""
    rows, columns = header.get("Rows"), header.get("Columns")
    if not all(isinstance(n, int) and n > 0 for n in (rows, columns)):
        raise VolumeError(f"{folder.name}/{path.name}: its Rows and Columns ({rows!r} x {columns!r}) are not an "
                          "image size, so the file is damaged; remove it or export the series again")
    samples = header.get("SamplesPerPixel", 1)
    if samples not in (1, None):
        raise VolumeError(f"{folder.name}/{path.name} is a colour image ({samples} samples per pixel, "
                          f"{header.get('PhotometricInterpretation', '')}); a volume needs grey slices: "
                          "remove it or export the series in greyscale")
    return rows, columns


def _numbers(header, keyword: str, count: int) -> np.ndarray:
    values = header.get(keyword)
    if values is None:
        raise VolumeError(f"{keyword} is missing")
    values = [values] if not isinstance(values, (list, tuple)) and not hasattr(values, "__len__") else values
    if len(values) != count:
        raise VolumeError(f"{keyword} has {len(values)} values where DICOM has {count}")
    numbers = np.array([float(v) for v in values])
    if not np.all(np.isfinite(numbers)):
        raise VolumeError(f"{keyword} is not finite ({', '.join(map(str, values))})")
    return numbers


def _geometry(folder: Path, files):
    """Sorted files, slice spacing, pixel spacing; refuses what would give a wrong volume."""
    sizes = {_image_size(folder, path, h) for path, h in files}
    if len(sizes) > 1:
        raise VolumeError(f"{folder.name}: the series mixes image sizes "
                          f"({', '.join(f'{r}x{c}' for r, c in sorted(sizes))}); export it again as one series")
    try:
        orientation = _numbers(files[0][1], "ImageOrientationPatient", 6)
        positions = np.array([_numbers(h, "ImagePositionPatient", 3) for _, h in files])
        pixel_spacing = tuple(_numbers(files[0][1], "PixelSpacing", 2))
    except VolumeError as exc:
        raise VolumeError(f"{folder.name}: {exc}, so the slices' order and spacing are unknown; export the "
                          "series with its geometry (ImagePositionPatient, ImageOrientationPatient, "
                          "PixelSpacing)") from None
    except (AttributeError, ValueError, TypeError):
        raise VolumeError(f"{folder.name}: the slices lack ImagePositionPatient, ImageOrientationPatient "
                          "or PixelSpacing, so their order and spacing are unknown; export the series "
                          "with its geometry") from None
    if min(pixel_spacing) <= 0:
        raise VolumeError(f"{folder.name}: PixelSpacing {pixel_spacing} is not positive; fix the series' header")
    row_length, column_length = np.linalg.norm(orientation[:3]), np.linalg.norm(orientation[3:])
    if abs(row_length - 1) > 0.01 or abs(column_length - 1) > 0.01 or abs(orientation[:3] @ orientation[3:]) > 0.01:
        raise VolumeError(f"{folder.name}: ImageOrientationPatient ({', '.join(f'{v:g}' for v in orientation)}) "
                          "is not two perpendicular unit directions; fix the series' header")
    if len(files) < 2:
        raise VolumeError(f"{folder.name} holds one DICOM slice; a volume needs at least 2")
    normal = np.cross(orientation[:3], orientation[3:])
    along = positions @ normal
    order = np.argsort(along, kind="stable")
    along = along[order]
    steps = np.diff(along)
    if np.any(steps <= 1e-6 * max(1.0, float(np.abs(along).max()))):
        raise VolumeError(f"{folder.name}: two slices share a position ({along[np.argmin(steps)]:.4g} mm along "
                          "the slice normal); the folder mixes series or holds duplicates")
    spacing = float(np.median(steps))
    uneven = np.abs(steps - spacing) > GAP_TOLERANCE * spacing
    if uneven.any():
        at = int(np.argmax(uneven))
        what = "a missing slice" if abs(steps[at] / spacing - round(steps[at] / spacing)) < GAP_TOLERANCE \
            and steps[at] > spacing else "uneven slice spacing"
        raise VolumeError(f"{folder.name}: {what} between slices {at + 1} and {at + 2} "
                          f"({steps[at]:.4g} mm apart where the others are {spacing:.4g} mm); "
                          "export the complete, evenly spaced series")
    # Array index (slice, row, column) -> LPS: a row steps down the image (the column direction,
    # ImageOrientationPatient[3:]), a column across it (the row direction, [:3]).
    world = np.eye(4)
    world[:3, 0] = spacing * normal
    world[:3, 1] = pixel_spacing[0] * orientation[3:]
    world[:3, 2] = pixel_spacing[1] * orientation[:3]
    world[:3, 3] = positions[order[0]]
    return [files[i] for i in order], (spacing, pixel_spacing[0], pixel_spacing[1]), world


def _rescale(header) -> tuple[float, float]:
    """(RescaleSlope, RescaleIntercept), 1 and 0 where absent or empty; refuses what is not one number."""
    values = []
    for keyword, default in (("RescaleSlope", 1.0), ("RescaleIntercept", 0.0)):
        value = header.get(keyword)
        try:
            values.append(default if value in (None, "") else float(value))
        except (TypeError, ValueError):
            raise VolumeError(f"{keyword} {value!r} of a slice is not one number; fix the series' header") from None
    return values[0], values[1]


def _pixels(path: Path, shape: tuple[int, int]) -> np.ndarray:
    """One slice's samples, as stored, or rescaled (float64, checked to fit float32)."""
    import pydicom
    dataset = pydicom.dcmread(path)
    syntax = getattr(getattr(dataset, "file_meta", None), "TransferSyntaxUID", None)
    if not any(keyword in dataset for keyword in ("PixelData", "FloatPixelData", "DoubleFloatPixelData")):
        raise VolumeError(f"{path.name} has no pixel data (an image header without its image); remove it or "
                          "export the series again")
    try:
        pixels = dataset.pixel_array
    except (RuntimeError, NotImplementedError, ValueError, AttributeError) as exc:
        detail = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        if syntax is None or not getattr(syntax, "is_compressed", True):
            raise VolumeError(f"{path.name} is damaged or truncated ({detail}); export the series again") from None
        name = getattr(syntax, "name", str(syntax))
        raise VolumeError(f"{path.name} is compressed as {name}, which pydicom cannot decode here "
                          f"({detail}); install a decoder: "
                          "pip install pylibjpeg pylibjpeg-libjpeg pylibjpeg-openjpeg") from None
    if pixels.shape != tuple(shape):
        raise VolumeError(f"{path.name}'s pixels are {'x'.join(map(str, pixels.shape))} where its header and the "
                          f"series say {'x'.join(map(str, shape))}; remove it or export the series again")
    slope, intercept = _rescale(dataset)
    if slope == 1 and intercept == 0:
        return pixels
    with np.errstate(all="ignore"):
        scaled = pixels * np.float64(slope) + np.float64(intercept)
    if not np.all(np.abs(scaled) <= np.finfo(np.float32).max):
        raise VolumeError(f"{path.name}: its RescaleSlope {slope:g} and RescaleIntercept {intercept:g} take "
                          "samples beyond what float32 holds (or are not finite); fix the header")
    return scaled


def _along_normal(files) -> np.ndarray | None:
    """Each file's position along the slice normal (rounded to a micrometre), or None where the geometry
    is missing (_geometry then says so)."""
    try:
        orientation = _numbers(files[0][1], "ImageOrientationPatient", 6)
        positions = np.array([_numbers(h, "ImagePositionPatient", 3) for _, h in files])
    except (VolumeError, AttributeError, ValueError, TypeError):
        return None
    return np.round(positions @ np.cross(orientation[:3], orientation[3:]), 3)


def _time_number(header, keyword: str) -> float | None:
    value = header.get(keyword)
    try:
        return None if value in (None, "") else float(value)
    except (TypeError, ValueError):
        return None


def time_groups(folder: Path, files) -> tuple[str | None, list]:
    """(the keyword that orders them, the files of each time point in time order); (None, [files]) for a
    3-D series (no slice position repeats).  Time points with different slices are refused in one line."""
    along = _along_normal(files)
    if along is None or len(set(along.tolist())) == len(files):
        return None, [files]
    for keyword in TIME_KEYWORDS:
        numbers = [_time_number(h, keyword) for _, h in files]
        if None in numbers or len(set(numbers)) < 2:
            continue
        groups: dict[float, list] = {}
        for entry, number, position in zip(files, numbers, along):
            groups.setdefault(number, []).append((entry, position))
        if any(len({position for _, position in group}) != len(group) for group in groups.values()):
            continue   # a position twice within one time point: not this keyword's grouping
        ordered = [groups[number] for number in sorted(groups)]
        first = sorted(position for _, position in ordered[0])
        for t, group in enumerate(ordered[1:], 1):
            if sorted(position for _, position in group) != first:
                raise VolumeError(f"{folder.name}: time point {t} ({keyword} {sorted(groups)[t]:g}) has "
                                  f"{len(group)} slices at other positions than time point 0's {len(first)}; "
                                  "export the complete temporal series")
        return keyword, [[entry for entry, _ in group] for group in ordered]
    return None, [files]   # _geometry names the shared position


def load_dicom_folder(folder: Path, series: str | None = None, progress: Progress | None = None,
                      time: int | None = None):
    """(array (slices, rows, columns), spacing, notes, (index -> LPS matrix, "LPS")) of the DICOM series
    (of its time point `time`, for a temporal series)."""
    try:
        import pydicom  # noqa: F401
    except ImportError:
        raise VolumeError(f"{folder.name} is a folder: reading DICOM needs pydicom; "
                          "pip install pydicom") from None
    notes: list[str] = []
    with library_messages(notes, "pydicom"):  # pydicom logs odd values as well as warning of them
        data, spacing, more_notes, world = _load(folder, series, progress, time)
    return data, spacing, more_notes + notes, world


def _load(folder: Path, series: str | None, progress: Progress | None, time: int | None):
    all_series = _series_files(folder, progress)
    keyword, groups = time_groups(folder, _pick_series(folder, all_series, series))
    time_notes = []
    if keyword is None:
        refuse_time(time, folder.name, 3)
        picked = groups[0]
    else:
        index = time_index(time, len(groups), folder.name)
        picked = groups[index]
        time_notes = [time_note(index, len(groups)),
                      f"DICOM temporal series: {len(groups)} time points by {keyword}"]
    files, spacing, world = _geometry(folder, picked)
    header = files[0][1]
    # The size is refused from the headers before a pixel is read (4 bytes a sample where any slice
    # is rescaled); the volume is then allocated once, in the first slice's type (float32 where any is
    # rescaled or stored as floats), and filled a slice at a time: no list of slices and a stacked copy.
    rescaled = any(_rescale(h) != (1.0, 0.0) for _, h in files)
    rows, columns = _image_size(folder, files[0][0], header)
    bytes_per_sample = 4 if rescaled else max(1, int(header.get("BitsAllocated", 16) or 16) // 8)
    refuse_if_too_big((len(files), rows, columns), bytes_per_sample, folder.name)
    data = None
    for number, (path, _) in enumerate(files, 1):
        pixels = _pixels(path, (rows, columns))
        if data is None:
            floats = rescaled or pixels.dtype.kind == "f"
            data = np.empty((len(files), rows, columns), np.float32 if floats else pixels.dtype)
        elif data.dtype.kind != "f" and not np.can_cast(pixels.dtype, data.dtype):
            raise VolumeError(f"{path.name} stores its samples as {pixels.dtype} where the series' first slice "
                              f"has {data.dtype}; export the series again as one")
        data[number - 1] = pixels
        if number % 10 == 0:
            report(progress, 0.3 + 0.7 * number / len(files), f"reading {folder.name} slices")
    notes = [f"DICOM series {_describe(files)}, {shape_text(data.shape)} "
             f"(slice, row, column), {spacing[0]:.4g} x {spacing[1]:.4g} x {spacing[2]:.4g} mm"]
    if len(all_series) > 1:
        notes.append(f"{folder.name} holds {len(all_series)} series; showing {header.get('SeriesInstanceUID', '')}")
    return data, spacing, notes + time_notes, (world, "LPS")
