"""Which coarse preview a moving level gets: the finest sample step whose measured frame time stays under a
target.  No GL here: the GPU side (gfx/scene.py) records how long each frame took and asks for the step.

A frame while a level moves costs a floor (the panel, the other levels, the swap: what a frame that extracts
nothing takes) plus the moving level's work, its extraction and drawing, which falls with the step: drawing
with the triangles (1/step^2), extraction with the cells (1/step^3).  Each step's frame time is kept as the
median of its last few frames, refreshed as the step is used and forgotten when it has not been for a while
(the scene moves on: a zoom, another level's mesh), so a step found slow is tried again now and then.  A step
never measured is estimated from the nearest measured one with the work scaled as the triangles are (drawing
dominates on llvmpipe); where extraction dominates a finer step's estimate is low, and it is measured the one
frame it is tried.  With nothing measured yet the caller's first guess (a triangle budget, gfx/surface.py)
stands.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from statistics import median

TARGET_FRAME_MS = 40.0
"""The frame time a drag aims under: below the 50 ms median the viewer promises on llvmpipe at 1280x800
(frames vary by a fifth or so as the level crosses more or less of the volume)."""
RECENT_FRAMES = 5
"""Frames of a step whose median is its frame time: one slow frame (a page fault, a JIT) does not move it."""
FORGET_AFTER = 30
"""Frames recorded after which a step's last measurement no longer counts: it may be tried again (a second
of dragging; at 120 a step measured slow in the first frames after opening, page faults and JIT, kept a
1024^3 map's drag at step 8 with 20 ms frames for a whole 60-frame bench)."""


def estimated_ms(step: int, measured: Mapping[int, float], floor_ms: float = 0.0) -> float | None:
    """A frame's time at `step`: its measured one, else from the nearest measured step (the slower estimate
    where two are as near) with the work above `floor_ms` (half that step's frame at least) scaled as the
    triangles, 1/step^2; None with nothing measured."""
    if step in measured:
        return measured[step]
    if not measured:
        return None
    nearest = min(abs(known - step) for known in measured)
    estimates = []
    for known, ms in measured.items():
        if abs(known - step) == nearest:
            floor = min(floor_ms, ms / 2)   # a frame at the floor (noise) would make every step look free
            estimates.append(floor + (ms - floor) * (known / step) ** 2)
    return max(estimates)


def paced_step(measured: Mapping[int, float], first_guess: int, max_step: int, target_ms: float = TARGET_FRAME_MS,
               floor_ms: float = 0.0) -> int:
    """The finest step from 1 to `max_step` whose frame time (`estimated_ms`) is within `target_ms`;
    `max_step` where none is; `first_guess` (clamped to 1..max_step) with nothing `measured`."""
    max_step = max(1, int(max_step))
    if not measured:
        return min(max(1, int(first_guess)), max_step)
    for step in range(1, max_step + 1):
        if estimated_ms(step, measured, floor_ms) <= target_ms:
            return step
    return max_step


class FramePace:
    """The frame times of a moving level, per preview step, and of frames that extracted nothing (the floor);
    `step` picks the next preview's step from them (`paced_step`)."""

    def __init__(self, target_ms: float = TARGET_FRAME_MS, recent: int = RECENT_FRAMES,
                 forget_after: int = FORGET_AFTER):
        self.target_ms, self.recent, self.forget_after = float(target_ms), int(recent), int(forget_after)
        self._frames: dict[int, deque[tuple[int, float]]] = {}   # step -> its last (frame number, ms)
        self._floor: deque[float] = deque(maxlen=self.recent)
        self._count = 0   # moving frames recorded

    def record(self, step: int, ms: float) -> None:
        """A frame that drew the moving level's mesh at `step` took `ms`."""
        self._count += 1
        self._frames.setdefault(int(step), deque(maxlen=self.recent)).append((self._count, float(ms)))

    def record_floor(self, ms: float) -> None:
        """A frame that extracted nothing took `ms`."""
        self._floor.append(float(ms))

    @property
    def measured(self) -> dict[int, float]:
        """Each step's frame time: the median of its recent frames, for the steps used lately."""
        return {step: median(ms for _, ms in frames) for step, frames in self._frames.items()
                if self._count - frames[-1][0] < self.forget_after}

    @property
    def floor_ms(self) -> float:
        """The median time of recent frames that extracted nothing (what a frame costs besides extraction); 0 before one
        is recorded."""
        return median(self._floor) if self._floor else 0.0

    def step(self, first_guess: int, max_step: int) -> int:
        """The step for the next frame of a moving level (`paced_step` on what was measured)."""
        return paced_step(self.measured, first_guess, max_step, self.target_ms, self.floor_ms)

    def forget(self) -> None:
        """What was measured no longer holds (another volume, other meshes on show): start again."""
        self._frames.clear()
        self._floor.clear()


def pace_text(pace: FramePace) -> str:
    """What chose the preview's step, in a line (the Stats line's tooltip)."""
    measured = pace.measured
    if not measured:
        return "no frame measured yet: the step whose mesh keeps under the triangle budget"
    times = ", ".join(f"1/{step} {ms:.0f} ms" for step, ms in sorted(measured.items()))
    return (f"the finest step whose frames keep under {pace.target_ms:.0f} ms while the level moves (else the "
            f"coarsest); measured {times}")
