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


def time_note(index: int, count: int) -> TimeNote:
    note = TimeNote(f"4-D file: showing time point {index} of {count} (use --time N)")
    note.count = int(count)
    return note


def time_points_of(notes) -> int:
    """How many time points the notes of a loaded file say it holds (1: a 3-D file)."""
    return max((note.count for note in notes if isinstance(note, TimeNote)), default=1)


def time_index(time: int | None, count: int, what: str) -> int:
    index = 0 if time is None else int(time)
    if not 0 <= index < count:
        raise VolumeError(f"--time {time} is past the end: {what} has {count} time points "
                          f"(use --time 0..{count - 1})")
    return index


def refuse_time(time: int | None, what: str, ndim: int) -> None:
    if time is not None and ndim == 3:
        raise VolumeError(f"--time {time} given but {what} is 3-D (one time point); drop --time")


def select_time(data: np.ndarray, time_axis: int, time: int | None, what: str):
    """One 3-D volume out of a 4-D array; (array, notes). 3-D arrays pass through."""
    if data.ndim != 4:
        refuse_time(time, what, data.ndim)
        return data, []
    index = time_index(time, data.shape[time_axis], what)
    return np.take(data, index, axis=time_axis), [time_note(index, data.shape[time_axis])]
