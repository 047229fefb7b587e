"""Asking the viewer for a volume: a built-in name, a file, an 'expr:...' or a saved scene, read on a worker thread
(jobs.py; expr: at once, with the window's GL context) and downsampled where it is over the memory budget; the GPU
side (gfx/scene.py) puts the answer to the newest request on show.  No GL here."""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

from ...core.budget import MemoryBudget
from ...volumes import Volume, open_volume
from ...volumes.reading import maps_within
from .big_volume import downsampled
from .jobs import Response
from .scene_file import is_scene_file, read_scene, volume_spec


class Opened(NamedTuple):
    """An "open" job's answer: the volume read, and what the viewer shows of it (every `step`-th sample
    of a big one)."""
    spec: str
    volume: Volume
    shown: Volume
    step: int


def read_for_viewer(opener, spec: str, open_options: dict, budget: MemoryBudget, refusal=None,
                    progress=None) -> Opened:
    """Read `spec` with `opener` (open_volume's signature) and downsample it if it is over `budget` or (where
    `refusal(shape)` says why) more than the extractor here can hold (big_volume.downsampled)."""
    if maps_within(spec, budget.bytes):   # a file over the budget is not read whole into memory
        open_options = {"map_files": True, **open_options}
    volume = opener(spec, progress=progress, **open_options)
    shown, step = downsampled(volume, budget, refusal)
    return Opened(spec, volume, shown, step)


class VolumeOpening:
    """A `ViewerState`'s requests for volumes (`open`), their progress (`loading`) and answers (`opened`), and a
    scene file's scene while its volume is read (then `scene_to_apply`, for the view side)."""

    def __init__(self, state, opener=None):
        """`opener`: reads expr: volumes in the caller's thread (the window passes open_volume with its GL
        context, to sample them on its GPU) and a colour-by volume; other volumes are read on a worker thread."""
        self._state = state   # its jobs, memory budget, refusal and recent files
        self.opener = opener if opener is not None else open_volume
        self._pending_scene = None            # (request, scene, its path) while a scene's volume is read
        self.scene_to_apply: dict | None = None   # a scene whose volume is on show: the view side applies it

    def open(self, spec: str, **open_options) -> int:
        """Ask for the built-in name, file path or 'expr:...' `spec`: read on a worker thread (the panel
        shows its progress; expr: at once, with the opener); the GPU side puts it on show when the answer
        to this request, the newest, comes in.  The request's id."""
        if not open_options and is_scene_file(spec):   # a saved scene: its volume, then the scene on it
            return self._open_scene(spec)
        state, failure = self._state, f"could not open {spec[:80]}"
        if spec.strip().lower().startswith("expr:"):
            return state.jobs.submit("open", read_for_viewer, self.opener, spec, open_options, state.budget,
                                     state.refusal, inline=True, failure=failure)
        return state.jobs.submit("open", read_for_viewer, open_volume, spec, open_options, state.budget,
                                 state.refusal, message=f"opening {spec}", failure=failure)

    @property
    def loading(self):
        """The volume being read (its `fraction` and `message`), or None."""
        return self._state.jobs.current("open")

    def _open_scene(self, path: str) -> int:
        """Open a scene file (scene_file.py): its volume asked for as `open` asks; once that volume is on
        show, the view side puts the scene on it (`scene_to_apply`).  A bad scene raises its one line."""
        scene = read_scene(path)
        spec, options = volume_spec(scene)
        request = self.open(spec, **options)
        self._pending_scene = (request, scene, path)
        return request

    def opened(self, response: Response) -> Opened:
        """An "open" job's answer: its volume, or its error raised.  The answer to a scene's volume leaves
        the scene in `scene_to_apply` for the view side, which owns the camera, once it has shown it."""
        pending, self._pending_scene = self._pending_scene, None
        if response.error is not None:
            raise response.error
        recent = self._state.recent
        if pending is not None and pending[0] == response.request_id:
            self.scene_to_apply = pending[1]
            recent.add(pending[2])
        elif _names_a_file(response.value.spec):
            recent.add(response.value.spec)
        return response.value


def _names_a_file(spec: str) -> bool:
    """Whether `spec` is a file's path (for the recent files); a 2,000-character expr: is no file name,
    and asking the file system would raise "File name too long"."""
    if spec.strip().lower().startswith("expr:"):
        return False
    try:
        return Path(spec).is_file()
    except (OSError, ValueError):
        return False
