"""Which preview step a moving level gets, from the frames measured so far (model/pacing.py): each frame's time
recorded against the step it drew, forgotten when what it was measured with changes (GpuScene's)."""
from __future__ import annotations

from ..model.pacing import FramePace
from . import surface as surface_module

REST_S = 0.15                # a value (or a label map's look) unchanged this long gets its full-resolution mesh


class PreviewPacing:
    """The frame times of a moving level's previews, per step, and the step its next mesh gets."""

    def __init__(self):
        self.pace = FramePace()     # frame times while the level moves, per preview step
        self._key = None            # what they were measured with (the other levels, options)
        self.last_frame: int | None = None   # the step the last frame drew moving (0: a preview, idle)

    def record_frame(self, dt_seconds: float, key) -> None:
        """The last frame took `dt_seconds`: a moving frame's time for its step, an idle one's with a preview on
        show for the floor.  `key`: what the frames were measured with (another forgets them)."""
        if key != self._key:   # other levels' meshes or other cells: the frames measured no longer hold
            self.pace.forget()
            self._key = key
        elif dt_seconds > 0 and self.last_frame is not None:
            if self.last_frame:
                self.pace.record(self.last_frame, dt_seconds * 1000)
            else:
                self.pace.record_floor(dt_seconds * 1000)
        self.last_frame = None

    def step(self, surface, budget: int) -> int:
        """The step of a moving level's next mesh: the finest whose frames stay under the target, as measured
        (model/pacing.py); before any frame is measured, the step whose mesh fits `budget` triangles."""
        shape = surface.volume.data.shape
        first_guess = surface_module.preview_step(surface.full_triangles, shape, budget)
        return self.pace.step(first_guess, surface_module.coarsest_step(shape))
