"""Series: a 4-D file (NIfTI's 4th axis, NRRD's non-spatial axis, a TIFF time-lapse, a Zarr's leading
axis, a stack of .npy volumes) holds several 3-D volumes, its time points.  `--time N` picks one
(default 0; `--frame N` is its older name); the note that says so carries how many there are, which
`open_file` keeps as `Volume.time_points` (export's `--time all` writes one mesh per point)."""
from __future__ import annotations

import numpy as np

from .errors import VolumeError


class TimeNote(str):
    """The note "showing time point i of n", which also holds n (`count`)."""
    count: int


def time_note(index: int, count: int, text: str | None = None) -> TimeNote:
    """The note of a 4-D file on show: `text` or "showing time point i of n", holding the count."""
    note = TimeNote(text or f"4-D file: showing time point {index} of {count} (use --time N)")
    note.count = int(count)
    return note


def time_points_of(notes) -> int:
    """How many time points the notes of a loaded file say it holds (1: a 3-D file)."""
    return max((note.count for note in notes if isinstance(note, TimeNote)), default=1)


def time_index(time: int | None, count: int, what: str) -> int:
    """The time point to read (`time`, default 0); a VolumeError when it is past the `count` points of `what`."""
    index = 0 if time is None else int(time)
    if not 0 <= index < count:
        raise VolumeError(f"--time {time} is past the end: {what} has {count} time points "
                          f"(use --time 0..{count - 1})")
    return index


def refuse_time(time: int | None, what: str, ndim: int) -> None:
    """A VolumeError when --time is given for a 3-D volume (`ndim` 3)."""
    if time is not None and ndim == 3:
        raise VolumeError(f"--time {time} given but {what} is 3-D (one time point); drop --time")


def select_time(data: np.ndarray, time_axis: int, time: int | None, what: str):
    """One 3-D volume out of a 4-D array; (array, notes). 3-D arrays pass through."""
    if data.ndim != 4:
        refuse_time(time, what, data.ndim)
        return data, []
    index = time_index(time, data.shape[time_axis], what)
    return np.take(data, index, axis=time_axis), [time_note(index, data.shape[time_axis])]


# --- a series of 3-D files named by a pattern: 'run/field_*.npy' ------------------------------------
PATTERN_CHARACTERS = "*?["
MAX_SERIES_FILES = 100_000


def is_pattern(spec: str) -> bool:
    """A spec naming several files by a glob pattern (and not itself an existing path)."""
    from pathlib import Path
    return any(c in spec for c in PATTERN_CHARACTERS) and not Path(spec).expanduser().exists()


def natural_key(name: str):
    """'f_10' after 'f_9': digit runs compare as numbers."""
    import re
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", name)]


def series_files(pattern: str) -> list:
    """The files a glob pattern names, in natural order of their paths; one line where there are none."""
    import glob
    from pathlib import Path
    matches = sorted((Path(p) for p in glob.iglob(str(Path(pattern).expanduser())) if Path(p).is_file()),
                     key=lambda p: natural_key(str(p)))
    if not matches:
        raise VolumeError(f"no file matches {pattern}; check the pattern (quote it so the shell does not expand it)")
    if len(matches) > MAX_SERIES_FILES:
        raise VolumeError(f"{pattern} matches {len(matches):,} files, more than {MAX_SERIES_FILES:,} time points; "
                          "narrow the pattern")
    return matches


def same_shape(volume, first_shape, time: int) -> None:
    """A series' time points must all have the first one's shape (export --time all checks each)."""
    from .volume import shape_text
    if tuple(volume.data.shape) != tuple(first_shape):
        raise VolumeError(f"time point {time} ({volume.name}) is {shape_text(volume.data.shape)} where the "
                          f"series' first is {shape_text(first_shape)}; a series' time points must have one shape")
