"""The viewer's state: the volume on show, its GPU extractor, the iso value, display flags, messages.

The panel, the keys and the tests all change the viewer through this object;
the window loop calls `update()` once a frame, which re-extracts whenever the
iso value changed since the last extraction (so dragging the slider re-extracts
on every frame in which the value moved, and never when it did not).
"""
from __future__ import annotations

import json
import math
import os
import threading
from pathlib import Path

import moderngl

from ..volumes import Volume, open_volume
from .renderer import SurfaceStyle

ANIMATION_PERIOD_S = 6.0          # one sweep up and back down
ANIMATION_SPAN = (0.02, 0.98)     # fractions of the range; the very ends give empty surfaces
MAX_RECENT = 8

# What a bad volume or extraction can raise: one-line messages meant for the user.
USER_ERRORS = (ValueError, OSError, moderngl.Error)


def one_line(exc: Exception) -> str:
    """The panel shows one line: GL driver errors (shader logs) come with several."""
    return " ".join(str(exc).split()) or type(exc).__name__


class RecentFiles:
    """Files the user opened, newest first, kept in a small JSON file across sessions."""

    def __init__(self, path: Path | None):
        self.path = path
        self.paths: list[str] = []
        if path is not None:
            try:
                loaded = json.loads(Path(path).read_text())
                self.paths = [p for p in loaded if isinstance(p, str)][:MAX_RECENT]
            except (OSError, ValueError):
                pass  # no history yet, or an unreadable one: start afresh

    @staticmethod
    def default_path() -> Path:
        config = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
        return Path(config) / "isoscope" / "recent.json"

    def add(self, path: str) -> None:
        path = str(Path(path).resolve())
        self.paths = [path] + [p for p in self.paths if p != path][:MAX_RECENT - 1]
        if self.path is not None:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self.path.write_text(json.dumps(self.paths, indent=1))
            except OSError:
                pass  # a read-only home must not stop the viewer


class PendingLoad:
    """A volume being read on a worker thread, so the window keeps drawing (and shows progress).

    Only reading and checking happen here: the GL upload needs the window's context,
    which belongs to the main thread, so `ViewerState.update` shows the result.
    """

    def __init__(self, spec: str, open_options: dict):
        self.spec = spec
        self.fraction = 0.0
        self.message = f"opening {spec}"
        self.volume: Volume | None = None
        self.error: str | None = None
        self._thread = threading.Thread(target=self._read, args=(open_options,), daemon=True,
                                        name=f"isoscope load {spec}")
        self._thread.start()

    def _read(self, open_options: dict) -> None:
        try:
            self.volume = open_volume(self.spec, progress=self._report, **open_options)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
        except Exception as exc:  # a loader's bug must not take the viewer down with it
            self.error = f"could not open {self.spec}: {type(exc).__name__}: {one_line(exc)}"

    def _report(self, fraction: float, message: str) -> None:
        self.fraction, self.message = float(fraction), message

    def done(self, wait_s: float = 0.0) -> bool:
        self._thread.join(wait_s)
        return not self._thread.is_alive()


class ViewerState:
    def __init__(self, ctx: moderngl.Context, recent: RecentFiles | None = None):
        self.ctx = ctx                   # the context the extractor's buffers must live in (the window's)
        self.volume: Volume | None = None
        self.extractor = None            # isoscope.extractor.Extractor for `volume`
        self.iso = 0.0
        self._extracted_iso: float | None = None
        self.style = SurfaceStyle()
        self.animating = False
        self._animation_phase = 0.0
        self.error: str | None = None    # shown in the panel until the next successful action
        self.message: str | None = None  # e.g. where the last screenshot went
        self.recent = recent if recent is not None else RecentFiles(None)
        self.volume_serial = 0           # bumps on every new volume: the window refits its camera
        self.frame_ms = 0.0
        self.gl_renderer = ctx.info.get("GL_RENDERER", "unknown")
        self.loading: PendingLoad | None = None  # a volume being read in the background

    # --- volumes -----------------------------------------------------------
    def open(self, spec: str, **open_options) -> bool:
        """Open a built-in name, file path or 'expr:...'; on failure keep the current volume and set `error`."""
        try:
            # ctx: an expr: volume is sampled on the GPU in the viewer's own context.
            volume = open_volume(spec, ctx=self.ctx, **open_options)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        shown = self.show(volume)
        if shown and Path(spec).is_file():
            self.recent.add(spec)
        return shown

    def open_in_background(self, spec: str, **open_options) -> None:
        """Like `open`, but read on a worker thread: the panel shows a progress bar meanwhile, and
        `update` puts the volume on show (or its error in the panel) when it is read.  expr:
        volumes are sampled on the GPU, in this thread's context, so they open at once."""
        if spec.strip().lower().startswith("expr:"):
            self.open(spec, **open_options)
            return
        self.loading = PendingLoad(spec, open_options)
        self.error = None

    def _finish_loading(self) -> None:
        pending, self.loading = self.loading, None
        if pending.error is not None:
            self.error = pending.error  # the volume on show stays
        elif self.show(pending.volume) and Path(pending.spec).is_file():
            self.recent.add(pending.spec)

    def show(self, volume: Volume, iso: float | None = None) -> bool:
        """Upload `volume` to the GPU and extract its first surface; the old volume stays on failure."""
        if not self._upload(volume, volume.gradient_direction):
            return False
        low, high = self.extractor.value_range
        first_iso = iso if iso is not None else volume.default_level
        self.iso = (low + high) / 2 if first_iso is None else min(max(float(first_iso), low), high)
        self.volume_serial += 1
        self.update(0.0)
        return self.error is None

    @property
    def inside_below(self) -> bool:
        """True when the object is where values are below the level (a signed distance)."""
        return self.volume is not None and self.volume.gradient_direction == "ascent"

    def set_inside_below(self, below: bool) -> bool:
        """Say which side of the level the object is on, for the volume on show: its normals turn
        to point out of it.  Camera and iso value stay."""
        direction = "ascent" if below else "descent"
        if self.volume is None or direction == self.volume.gradient_direction:
            return False
        if not self._upload(self.volume, direction):
            return False
        self.volume.gradient_direction = direction
        self.update(0.0)
        return self.error is None

    def _upload(self, volume: Volume, gradient_direction: str) -> bool:
        """A new extractor for `volume` replaces the old one; on failure the old one stays."""
        from ..extractor import Extractor  # imported late: `isoscope --help` needs no GL code
        try:
            extractor = Extractor(volume.checked, spacing=volume.spacing,
                                  gradient_direction=gradient_direction, ctx=self.ctx)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            return False
        if self.extractor is not None:
            self.extractor.release()
        self.volume, self.extractor = volume, extractor
        self._extracted_iso = None
        self.error = None
        return True

    # --- iso ---------------------------------------------------------------
    @property
    def value_range(self) -> tuple[float, float]:
        return self.extractor.value_range if self.extractor is not None else (0.0, 1.0)

    def set_iso(self, value: float) -> None:
        low, high = self.value_range
        self.iso = min(max(float(value), low), high)

    def nudge_iso(self, fraction_of_range: float) -> None:
        low, high = self.value_range
        self.set_iso(self.iso + fraction_of_range * (high - low))

    def toggle_animation(self) -> None:
        self.animating = not self.animating
        if self.animating:
            # Start the sweep from the current value so the surface does not jump.
            low, high = self.value_range
            start, end = ANIMATION_SPAN
            fraction = ((self.iso - low) / (high - low) - start) / (end - start) if high > low else 0.0
            self._animation_phase = math.acos(1 - 2 * min(max(fraction, 0.0), 1.0)) / (2 * math.pi)

    # --- per frame ---------------------------------------------------------
    def update(self, dt_seconds: float) -> bool:
        """Advance the animation and re-extract if the iso value moved; True when it re-extracted."""
        if self.loading is not None and self.loading.done():
            self._finish_loading()
        if self.extractor is None:
            return False
        if self.animating:
            self._animation_phase = (self._animation_phase + dt_seconds / ANIMATION_PERIOD_S) % 1.0
            low, high = self.value_range
            start, end = ANIMATION_SPAN
            sweep = (1 - math.cos(2 * math.pi * self._animation_phase)) / 2  # 0 -> 1 -> 0, eased at the ends
            self.iso = low + (high - low) * (start + (end - start) * sweep)
        if self.iso == self._extracted_iso:
            return False
        try:
            self.extractor.extract(self.iso)
        except USER_ERRORS as exc:
            self.error = one_line(exc)
            self.animating = False
        self._extracted_iso = self.iso  # also on failure: do not retry the same value every frame
        return True

    # --- stats for the panel ----------------------------------------------
    @property
    def n_vertices(self) -> int:
        return self.extractor.n_vertices if self.extractor is not None else 0

    @property
    def n_triangles(self) -> int:
        return self.extractor.n_triangles if self.extractor is not None else 0

    @property
    def extract_ms(self) -> float:
        return self.extractor.last_extract_ms if self.extractor is not None else 0.0

    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The volume's box in world units: [0, (n-1) * spacing] along each axis."""
        if self.volume is None:
            return (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
        upper = tuple((n - 1) * s for n, s in zip(self.volume.data.shape, self.volume.spacing))
        return (0.0, 0.0, 0.0), upper

    def release(self) -> None:
        if self.extractor is not None:
            self.extractor.release()
            self.extractor = None
