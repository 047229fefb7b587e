"""4-D files: pick one 3-D volume (--frame N, default 0) and say so."""
from __future__ import annotations

import numpy as np

from .errors import VolumeError


def frame_index(frame: int | None, n_frames: int, what: str) -> int:
    index = 0 if frame is None else int(frame)
    if not 0 <= index < n_frames:
        raise VolumeError(f"--frame {frame} is out of range: {what} has {n_frames} frames "
                          f"(use --frame 0..{n_frames - 1})")
    return index


def frame_note(index: int, n_frames: int) -> str:
    return f"4-D file: showing frame {index} of {n_frames} (use --frame N)"


def refuse_frame(frame: int | None, what: str, ndim: int) -> None:
    if frame is not None and ndim == 3:
        raise VolumeError(f"--frame {frame} given but {what} is 3-D (a single frame); drop --frame")


def select_frame(data: np.ndarray, frame_axis: int, frame: int | None, what: str):
    """One 3-D volume out of a 4-D array; (array, notes). 3-D arrays pass through."""
    if data.ndim != 4:
        refuse_frame(frame, what, data.ndim)
        return data, []
    index = frame_index(frame, data.shape[frame_axis], what)
    return np.take(data, index, axis=frame_axis), [frame_note(index, data.shape[frame_axis])]
