"""The panel's Time section: a series' time slider, play button (frame rate, loop / bounce), the
fixed value range, and Record, which writes the frames as they are drawn (without the panel) to a movie.

Plugged into `Panel.draw` (panel.py); its keys reach the window through `keys()`: `[` and `]` step back
and on.  Every change goes through the state's time axis (model/series.py); the window hands each drawn
frame to `capture` (a no-op unless recording), after the scene is drawn and before the panel."""
from __future__ import annotations

import queue
import threading
import time
from pathlib import Path

from ...errors import InputError
from ...io.movie import MovieWriter, movie_kind
from ..gfx.renderer import read_rgb
from ..model.errors import USER_ERRORS, one_line
from ..model.series import MAX_FPS, PLAY_MODES
from ..model.state import ViewerState
from .gui import act, choose, imgui, tooltip

RECORD_FPS = 30.0          # a recording's default frame rate: each drawn frame is written as often as wall time asks
MAX_RECORD_FPS = 240.0     # as `isoscope movie --fps`
RECORD_QUEUE = 8           # frames waiting for the encoder at most (the frame loop waits beyond)
MAX_REPEAT = 30            # a frame written at most this often: a window left minimised is a second's gap


def next_movie_path(directory, stem: str = "isoscope") -> Path:
    """`directory/isoscope-YYYYmmdd-HHMMSS.mp4`, with -2, -3 ... when that name is taken."""
    directory = Path(directory)
    base = f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}"
    candidate, counter = directory / f"{base}.mp4", 2
    while candidate.exists():
        candidate, counter = directory / f"{base}-{counter}.mp4", counter + 1
    return candidate


class Recorder:
    """Frames as the window draws them, written to a movie on a worker thread at `fps` (the movie's frame rate,
    the panel's field beside Record) in wall time (a frame drawn slower than that is written again; frames in
    between are skipped), until `stop`."""

    def __init__(self):
        self.fps = RECORD_FPS        # the next recording's frame rate
        self.path: Path | None = None
        self.frames = 0              # frames handed to the encoder
        self.message: str | None = None   # the last recording's outcome ("wrote ...", or why not)
        self._writer: MovieWriter | None = None
        self._queue: queue.Queue | None = None
        self._thread: threading.Thread | None = None
        self._started = 0.0
        self._rate = RECORD_FPS      # the recording under way's frame rate
        self._size = None
        self._error: BaseException | None = None

    @property
    def recording(self) -> bool:
        """Whether a movie is being recorded."""
        return self._writer is not None

    def set_fps(self, fps: float) -> None:
        """The frame rate of the recordings started from now (one under way keeps its own)."""
        fps = float(fps)
        if not 1.0 <= fps <= MAX_RECORD_FPS:   # NaN too
            raise InputError(f"record at {fps:g} fps: give 1 to {MAX_RECORD_FPS:g} frames per second")
        self.fps = fps

    def start(self, path) -> None:
        """Record into `path` (.mp4, .gif or a folder/) at `fps`; a bad name raises its one line."""
        path = Path(path)
        kind = movie_kind(path, "record to")
        if kind != "folder" and not path.parent.is_dir():
            raise InputError(f"record to {path}: the folder {path.parent} does not exist; pick another")
        self._rate = self.fps
        self._writer = MovieWriter(path, self._rate, kind)
        self.path, self.frames, self._size, self._error, self.message = path, 0, None, None, None
        self._queue = queue.Queue(RECORD_QUEUE)
        self._thread = threading.Thread(target=self._encode, daemon=True, name="isoscope record")
        self._thread.start()
        self._started = time.perf_counter()

    def capture(self, framebuffer, size) -> None:
        """The frame just drawn in `framebuffer` (its `size`), or the pixels `framebuffer()` gives where it is
        a function (called only for a frame due), written as often as the frame rate asks since the last;
        nothing while not recording."""
        if not self.recording:
            return
        if self._error is not None or (self._size is not None and tuple(size) != self._size):
            why = self._error or "the window was resized"
            self.stop(f"recording stopped ({why})")
            return
        due = int((time.perf_counter() - self._started) * self._rate) + 1 - self.frames
        if due <= 0:
            return
        if due > MAX_REPEAT:
            self._started += (due - MAX_REPEAT) / self._rate
            due = MAX_REPEAT
        self._size = tuple(size)
        self._queue.put((framebuffer() if callable(framebuffer) else read_rgb(framebuffer, size), due))
        self.frames += due

    def _encode(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self._error is not None:
                continue
            pixels, repeat = item
            try:
                for _ in range(repeat):
                    self._writer.append(pixels)
            except Exception as exc:   # noqa: BLE001 - shown in the panel; the recording stops
                self._error = exc

    def stop(self, why: str | None = None) -> Path | None:
        """Finish the file; its path (None where nothing could be written: `message` says why)."""
        if not self.recording:
            return None
        self._queue.put(None)
        self._thread.join()
        writer, self._writer = self._writer, None
        try:
            if self._error is not None:
                raise self._error
            path = writer.close()
        except (OSError, ValueError) as exc:
            writer.abort()
            self.message = f"recording not written: {exc}"
            return None
        seconds = writer.frames / self._rate
        self.message = (f"{why + ': ' if why else ''}wrote {path} ({writer.frames} frames, {seconds:.1f} s at "
                        f"{self._rate:g} fps)")
        return path

    @property
    def progress_line(self) -> str:
        """The status line while recording: the movie's length so far, its frames and its file."""
        seconds = self.frames / self._rate
        return f"recording {seconds:.1f} s, {self.frames} frames -> {self.path.name}"


def time_text(series) -> str:
    """The label beside the time slider: the time point drawn (`shown`), not the one asked for (`index`),
    which during Play runs a read ahead of the mesh on screen; "-> N" while N is read."""
    last = series.count - 1
    text = f"{series.shown} of 0..{last}"
    return text if series.index == series.shown else f"{text} -> {series.index}"


class TimeSection:
    """The panel's Time section: the time slider and playback for a series, and Record for any volume."""

    def __init__(self):
        self.recorder = Recorder()
        self.record_dir = Path(".")   # the window sets its screenshot folder
        self.record_name = ""         # typed in the panel; empty: a new .mp4 in record_dir
        self._state: ViewerState | None = None

    def draw(self, state: ViewerState, camera) -> None:
        """The time slider and playback for a series; Record for any volume."""
        self._state = state   # the keys' (the window's state)
        if state.volume is None:
            return
        if not imgui.collapsing_header("Time", imgui.TreeNodeFlags_.default_open):
            return
        if state.series.active:
            self._time_controls(state)
        self._record_controls(state)

    def _time_controls(self, state: ViewerState) -> None:
        series = state.series
        last = series.count - 1
        width = imgui.calc_text_size(f"{last} of 0..{last} -> {last}").x   # beside the slider, not under its grab
        spacing = imgui.get_style().item_spacing.x
        imgui.set_next_item_width(-width - spacing)
        changed, index = imgui.slider_int("##time", series.index, 0, last, "")
        if changed:
            act(state, series.go_to, index)
        tooltip("the series' time point ([ and ] step back and on)")
        imgui.same_line()
        text = time_text(series)
        imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + width - imgui.calc_text_size(text).x)
        imgui.text(text)
        if imgui.button("<"):
            act(state, series.step, -1)
        imgui.same_line()
        if imgui.button("Pause" if series.playing else "Play"):
            act(state, series.toggle_play)
        imgui.same_line()
        if imgui.button(">"):
            act(state, series.step, +1)
        imgui.same_line()
        imgui.set_next_item_width(70)
        changed, fps = imgui.drag_float("fps", series.fps, 0.2, 1.0, MAX_FPS, "%.0f")   # a field: its number shows
        if changed:
            act(state, series.set_fps, fps)
        imgui.same_line()
        imgui.set_next_item_width(-1)
        choose(state, "##mode", series.mode, PLAY_MODES, series.set_mode)
        tooltip("loop: back to the first time point after the last; bounce: back and forth")
        toggled, fixed = imgui.checkbox("range of the whole series", series.fixed_range)
        if toggled:
            act(state, series.set_fixed_range, fixed)
        tooltip("the iso slider's range and the histogram: every time point's together, so they do not jump\n"
                "as time moves (off: the time point's own)")
        for job in (series.loading, series.range_loading):
            if job is not None:
                imgui.progress_bar(job.fraction, imgui.ImVec2(-1, 0), job.message)

    def _record_controls(self, state: ViewerState) -> None:
        recorder = self.recorder
        if recorder.recording:
            if imgui.button("Stop recording"):
                self._stop(state)
            imgui.text_wrapped(recorder.progress_line)
            return
        if imgui.button("Record"):
            path = self.record_name.strip() or next_movie_path(self.record_dir)
            act(state, recorder.start, path)
        tooltip("write the frames as they are drawn (without the panel) until Stop recording")
        imgui.same_line()
        imgui.set_next_item_width(imgui.calc_text_size("240 fps").x + 2 * imgui.get_style().frame_padding.x)
        changed, fps = imgui.drag_float("##record fps", recorder.fps, 0.2, 1.0, MAX_RECORD_FPS, "%.0f fps")
        if changed:
            act(state, recorder.set_fps, round(fps))
        tooltip("the movie's frame rate: frames written per second of the recording (drag, or ctrl+click to type)")
        imgui.same_line()
        imgui.set_next_item_width(-1)
        _, self.record_name = imgui.input_text_with_hint("##record", "new .mp4 in the screenshot folder",
                                                         self.record_name)
        tooltip(".mp4, .gif, or a folder/ for numbered PNGs")
        if recorder.message and recorder.message != state.message:
            state.message = recorder.message
            recorder.message = None

    def _stop(self, state: ViewerState) -> None:
        self.recorder.stop()
        state.message, self.recorder.message = self.recorder.message, None

    def capture(self, framebuffer, size) -> None:
        """The window's frame just drawn (scene only), for Record: a framebuffer, or a function giving it."""
        self.recorder.capture(framebuffer, size)

    def keys(self, camera) -> dict:
        """Characters this section answers in the window (as window.py's `_on_char` table)."""
        return {"[": lambda: self._step(-1), "]": lambda: self._step(+1)}

    def _step(self, delta: int) -> None:
        state = self._state
        if state is not None and state.series.active:
            try:
                state.series.step(delta)
            except USER_ERRORS as exc:
                state.error = one_line(exc)
