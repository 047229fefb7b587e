"""The time axis of a series on show: which time point, playing or not, its frame rate and
loop / bounce, and the time points read (and prepared) on a worker thread, a request id in and a
response out as model/jobs.py does.  No GL here: the GPU side (gfx/scene.py) asks `advance` once a
frame for the time point to put on show, uploads it and hands it back to `take_time_point`.

A series is what `open_volume` says holds several 3-D volumes (`Volume.time_points` > 1): a 4-D
NIfTI/NRRD/TIFF/Zarr/npy, a glob of 3-D files, a DICOM folder of several acquisitions.  Each time point
is opened again from the series' spec with `time=N` (and the options it was opened with), checked to
have the first one's shape, downsampled as the first was, and its histogram made, all on the worker.
While one time point shows, the next ones playback will want (READ_AHEAD of them, one read after
another; paused, the next one) are read ahead: playback does not wait for a read it could have started
earlier, and never runs ahead of the reads (a time point is only left once the next is on show).  One
read of the wanted time point runs at a time, so a slider dragged across a hundred reads the one it
rests on.

The value range and histogram are the time point's own, or with `fixed_range` the whole series' (read
once on a worker), so the iso slider and the histogram stay put while time moves.  Levels, slices,
clip, camera, mesh options, colour by and labels stay as time moves.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...core.budget import available_memory_bytes, shown_shape
from .big_volume import shown_as, view_recipe
from .errors import ViewerError
from .histogram import BINS, value_histogram
from .jobs import Jobs

PLAY_MODES = ("loop", "bounce")
DEFAULT_FPS = 10.0
MAX_FPS = 60.0
READ_WAIT_S = 120.0          # a render (wait) waits this long for a time point's read
READ_AHEAD = 3               # time points read ahead while playing: a read slower than a frame now and then
                             # (a loaded machine: 65-115 ms median, 500 ms at worst for the MNI T1) is caught up
RANGE_SAMPLES = 1 << 26      # the fixed range's histogram samples at most this many values of the series
HISTOGRAM_SAMPLES = 1 << 21  # a time point's histogram samples at most about this many (a regular sub-grid):
                             # the whole MNI T1 took 75-90 ms of the worker's ~90 per time point, its 1.1 M of
                             # every other sample ~10 ms, the same picture


class TimePoint(NamedTuple):
    """A time point read and prepared on the worker: the volume, what the viewer shows of it (every
    `step`-th sample of a big one) and the histogram of that."""
    index: int
    volume: object
    shown: object
    step: int
    histogram: np.ndarray


class SeriesRange(NamedTuple):
    """The whole series' value range and the histogram of its values over it."""
    value_range: tuple[float, float]
    histogram: np.ndarray


def read_time_point(spec: str, options: dict, index: int, shape, step: int,
                    recipe: tuple[str | None, int] = (None, 1), progress=None) -> TimePoint:
    """Time point `index` of the series `spec` (opened with `options`), refused in one line unless it
    has `shape` (the series' first shape); shown as the first was (`recipe`: big_volume.view_recipe): from
    the same pyramid level, at its place (origin), else every `step`-th sample of it."""
    from ...volumes import open_volume
    from ...volumes.time_points import same_shape
    volume = open_volume(spec, time=index, progress=progress, **options)
    same_shape(volume, shape, index)
    shown = shown_as(volume, recipe, step)
    _ = shown.checked   # a lazy (Zarr) time point is read here, on the worker, not when it is uploaded
    return TimePoint(index, volume, shown, step, sampled_histogram(shown.data, shown.value_range))


def sampled_histogram(data: np.ndarray, value_range) -> np.ndarray:
    """value_histogram of every step-th sample along each axis, about HISTOGRAM_SAMPLES of them at most."""
    step = 1
    while data.size > HISTOGRAM_SAMPLES * step**3:
        step += 1
    return value_histogram(data[::step, ::step, ::step], value_range)


def read_series_range(spec: str, options: dict, count: int, progress=None) -> SeriesRange:
    """The value range of every time point together, and their values' histogram over it (sampled on a
    regular sub-grid where the series holds more than RANGE_SAMPLES values)."""
    from ...volumes import open_volume
    low, high, samples = math.inf, -math.inf, []
    budget = max(RANGE_SAMPLES // count, 1 << 12)
    for index in range(count):
        progress(index / count, f"value range of the series: time point {index + 1} of {count}")
        volume = open_volume(spec, time=index, **options)
        low, high = min(low, volume.value_range[0]), max(high, volume.value_range[1])
        step = 1
        while volume.data.size > budget * step**3:
            step += 1
        samples.append(np.asarray(volume.data[::step, ::step, ::step]).ravel())
    counts = np.zeros(BINS)
    for sample in samples:
        counts += np.histogram(sample, bins=BINS, range=(low, high))[0] if high > low else 0
    return SeriesRange((float(low), float(high)), np.log1p(counts).astype(np.float32))


def read_ahead(volume, step: int = 1) -> int:
    """How many time points playback reads ahead: READ_AHEAD, fewer where they would take more than an
    eighth of the memory available (each is held as the viewer shows it, every `step`-th sample)."""
    if volume is None:
        return 1
    shown_bytes = math.prod(shown_shape(volume.data.shape, step)) * volume.data.dtype.itemsize
    return int(max(1, min(READ_AHEAD, available_memory_bytes() // 8 // max(shown_bytes, 1))))


class TimeAxis:
    """The series on show and where it is in time; empty (`count` 1) for a 3-D volume."""

    def __init__(self):
        self.fps = DEFAULT_FPS
        self.mode = "loop"
        self.fixed_range = False   # the value range and histogram: the whole series' (else the time point's)
        self.attach(None)

    def attach(self, volume, step: int = 1, shown=None) -> None:
        """A new volume on show (`state.show`: `shown`, its view, one step of which spans `step` of its
        samples): its time axis, at the time point it was opened at; every time point is shown as `shown` is."""
        self.sample_step = step
        self.recipe = view_recipe(volume, shown) if volume is not None and shown is not None else (None, 1)
        self.count = int(volume.time_points) if volume is not None else 1
        self.spec = volume.source if volume is not None else ""
        options = dict(volume.open_options) if volume is not None else {}
        self.index = self.shown = int(options.pop("time", None) or 0)   # wanted, and on show
        self.options = options
        self.shape = tuple(volume.data.shape) if volume is not None else None
        self._ahead = read_ahead(volume, step)
        self.playing, self.direction, self._clock = False, 1, 0.0
        self.series_range: SeriesRange | None = None
        self.range_changed = False                # the slider's range is to be set again (time_step)
        self._ready: dict[int, TimePoint] = {}    # read ahead, not yet on show
        self._reading: dict[str, tuple[int, int]] = {}   # "time"/"prefetch" -> (request id, time point)
        self._failed: set[int] = set()            # read ahead and refused: read again only when asked for
        self.jobs = Jobs()                        # a new series: the old one's reads are not wanted
        if self.active and self.fixed_range:
            self._read_range()

    @property
    def active(self) -> bool:
        """A series is on show (more than one time point)."""
        return self.count > 1

    @property
    def loading(self):
        """The read of the time point wanted (its `fraction` and `message`) while it is not on show, or None."""
        if self.index == self.shown:
            return None
        return self.jobs.current("time") or self.jobs.current("prefetch")

    @property
    def range_loading(self):
        """The whole series' range being read (its `fraction` and `message`), or None."""
        return self.jobs.current("range")

    # --- moving in time ------------------------------------------------------
    def go_to(self, index: int) -> None:
        """Show time point `index` once it is read (at once where it was read ahead)."""
        self._check_series()
        if not (float(index).is_integer() and 0 <= index < self.count):
            raise ViewerError(f"time point {index} is outside the series; it has {self.count} (0..{self.count - 1})")
        self.index = int(index)
        self._ask()

    def _ask(self) -> None:
        """Read the time point wanted unless it is read or being read; one such read at a time (a slider
        dragged across a hundred time points reads the one it rests on, not every one it passed)."""
        if (self.index != self.shown and self.index not in self._ready and not self._is_reading(self.index)
                and "time" not in self._reading):
            self._read(self.index, "time")

    def step(self, delta: int) -> None:
        """`delta` time points on (back, negative), wrapping round at the ends (keys [ and ])."""
        self._check_series()
        self.go_to((self.index + int(delta)) % self.count)

    def toggle_play(self) -> None:
        """Start or stop playback; starting reads the next time point ahead. ViewerError on a volume without a time
        axis."""
        self._check_series()
        self.playing, self._clock = not self.playing, 0.0
        if self.playing and self.index == self.shown:
            self._prefetch()

    def set_fps(self, fps: float) -> None:
        """Set playback's frames a second; a value that is not finite, not above 0 or over `MAX_FPS` is a ViewerError.
        """
        if not (math.isfinite(float(fps)) and 0 < float(fps) <= MAX_FPS):
            raise ViewerError(f"{float(fps):g} frames a second: give more than 0 and at most {MAX_FPS:g}")
        self.fps = float(fps)

    def set_mode(self, mode: str) -> None:
        """Set how playback goes on at the last time point (one of `PLAY_MODES`), starting forwards; another name is a
        ViewerError."""
        if mode not in PLAY_MODES:
            raise ViewerError(f"play mode {mode!r} is not one of {', '.join(PLAY_MODES)}")
        self.mode = mode
        self.direction = 1

    def set_fixed_range(self, fixed: bool) -> None:
        """The value range and histogram of the whole series (read on a worker the first time), or of the
        time point on show."""
        fixed = bool(fixed)
        if fixed == self.fixed_range:
            return
        self.fixed_range, self.range_changed = fixed, True
        if fixed and self.active and self.series_range is None and self.range_loading is None:
            self._read_range()

    def following(self) -> int:
        """The time point playback shows after the one wanted now."""
        return self._after(self.index, self.direction)[0]

    def _after(self, index: int, direction: int) -> tuple[int, int]:
        """(the time point playback shows after `index`, going `direction`; the direction then)."""
        if self.mode == "loop":
            return (index + 1) % self.count, direction
        if not 0 <= index + direction < self.count:
            direction = -direction
        return index + direction, direction

    def upcoming(self) -> list[int]:
        """The time points playback shows next, in order: READ_AHEAD of them (while paused, the next)."""
        index, direction, points = self.index, self.direction, []
        for _ in range(min(self._ahead if self.playing else 1, self.count - 1)):
            index, direction = self._after(index, direction)
            points.append(index)
        return points

    # --- once a frame ---------------------------------------------------------
    def advance(self, dt_seconds: float, wait: bool = False) -> TimePoint | None:
        """The playback clock `dt_seconds` on; the time point the GPU side puts on show now (read by the
        worker), or None.  A time point whose read failed raises its one line (the one on show stays;
        playback stops).  With `wait`, a read still running is waited for (a render shows the time
        point asked for)."""
        if self.playing and self.index == self.shown:   # the time point asked for is on show: time moves on
            self._clock += dt_seconds
            period = 1.0 / self.fps
            if self._clock >= period:
                self._clock = min(self._clock - period, period)   # no burst of frames after a slow read
                following, self.direction = self._after(self.index, self.direction)
                self.go_to(following)
        while True:
            self._take_responses(wait)
            self._ask()
            self._prefetch()   # the reads ahead follow each other on the worker, not one a frame
            if self.index != self.shown and self.index in self._ready:
                return self._ready.pop(self.index)
            if not (wait and self.index != self.shown and self._is_reading(self.index)):
                return None

    def _take_responses(self, wait: bool) -> None:
        for response in self.jobs.poll(READ_WAIT_S if wait else 0.0):
            if response.kind == "range":
                self._took_range(response)
                continue
            _, index = self._reading.pop(response.kind, (None, None))
            if response.error is None:
                self._ready[index] = response.value
                self._failed.discard(index)
            else:
                self._failed.add(index)
                if index == self.index:
                    self.playing, self.index = False, self.shown
                    raise response.error

    def _took_range(self, response) -> None:
        if response.error is not None:
            self.fixed_range = False
            raise ViewerError(f"the series' value range could not be read: {response.error}")
        self.series_range, self.range_changed = response.value, True

    def took(self, point: TimePoint) -> None:
        """The GPU side has put `point` on show: the ones after it are read ahead."""
        self.shown = point.index
        upcoming = self.upcoming()
        self._ready = {index: ready for index, ready in self._ready.items() if index in upcoming}
        self._prefetch()

    def _prefetch(self) -> None:
        """Read the first of the upcoming time points not read yet, one read ahead at a time."""
        if "prefetch" in self._reading or not self.active:
            return
        for index in self.upcoming():
            if index in self._failed:
                return
            if index != self.shown and index not in self._ready and not self._is_reading(index):
                self._read(index, "prefetch")
                return

    def _is_reading(self, index: int) -> bool:
        return any(reading == index for _, reading in self._reading.values())

    def _read(self, index: int, kind: str) -> None:
        """Read time point `index` on a worker: "time" (the one wanted) or "prefetch" (read ahead); a newer
        request of the same kind makes an older one's answer stale."""
        request = self.jobs.submit(kind, read_time_point, self.spec, self.options, index, self.shape, self.sample_step,
                                   self.recipe, message=f"reading time point {index}",
                                   failure=f"could not read time point {index}")
        self._reading[kind] = (request, index)

    def _read_range(self) -> None:
        self.jobs.submit("range", read_series_range, self.spec, self.options, self.count,
                         message="value range of the series", failure="could not read the series' value range")

    def _check_series(self) -> None:
        if not self.active:
            raise ViewerError("the volume on show has one time point; open a series (a 4-D file, a glob of files) "
                              "to move in time")


def time_step(state, dt_seconds: float, wait: bool = False) -> TimePoint | None:
    """Once a frame, for the GPU side: `state`'s time axis `dt_seconds` on (the slider's range set again
    where the fixed range was switched or has been read); the time point to upload and then hand to
    `take_time_point`, or None."""
    series = state.series
    point = series.advance(dt_seconds, wait)
    if series.range_changed and state.volume is not None:
        series.range_changed = False
        apply_value_range(state)
    return point


def take_time_point(state, point: TimePoint) -> None:
    """`state` (ViewerState) shows `point` of its series in place of the time point on show, the GPU side
    having taken it: the volume, its histogram and value range (the series' with `fixed_range`); levels
    (clamped into the range), slices, clip, mesh options and the object's side stay; colour by a value
    or gradient and a label map follow the new volume."""
    point.shown.gradient_direction = state.volume.gradient_direction
    state.volume, state.full_volume, state.step = point.shown, point.volume if point.step > 1 else None, point.step
    state.series.took(point)
    apply_value_range(state, point.histogram)
    if state.color_by is not None and state.color_by.spec in ("value", "gradient"):
        state.set_color_by(state.color_by.spec, state.color_by.colormap)
    if state.labels:
        state.labels.show(state.volume)


def apply_value_range(state, own_histogram=None) -> None:
    """The slider's range and the histogram: the whole series' where it is fixed and known, else the
    volume on show's; each level's value clamped into the range (not reset)."""
    series = state.series
    if series.fixed_range and series.series_range is not None:
        value_range, histogram = series.series_range
    else:
        value_range = state.volume.value_range
        histogram = own_histogram if own_histogram is not None else sampled_histogram(state.volume.data, value_range)
    levels = state.levels
    levels.value_range = (float(value_range[0]), float(value_range[1]))
    for level in levels:
        level.value = levels.clamp(level.value)
    state.histogram = histogram
