"""Asking the viewer to write what it shows: "Save mesh..." (the mesh on show, written by the GPU side on its next
frame: gfx/saving.py) and "Export full resolution" (a downsampled big volume's full mesh, written a chunk at a time
on a worker thread: big_volume.py, a background job).  No GL here."""
from __future__ import annotations

from .big_volume import FullResolutionExport
from .errors import ViewerError, one_line
from .jobs import Response


class SaveRequests:
    """A `ViewerState`'s save request, waiting for the GPU side (`save_request`), and its full-resolution export."""

    def __init__(self, state):
        self._state = state   # the volume on show, its full volume, level and jobs
        self.save_request: str | None = None   # "Save mesh..." chosen in the panel: the GPU side writes it
        self._export: FullResolutionExport | None = None   # the last full-resolution export, to stop on closing

    def request_save(self, path) -> None:
        """Save the mesh on show to `path` (the GPU side reads it back and writes it on its next frame)."""
        if self._state.volume is None:
            raise ViewerError("no surface to save yet; open a volume first")
        self.save_request = str(path)

    def export_full_resolution(self, path) -> int:
        """Write the full-resolution mesh of a downsampled big volume at the selected level to `path`,
        a chunk at a time on a worker thread, a background job; its answer (`exported`) says when it is
        written, or why not.  The request's id."""
        state = self._state
        if state.full_volume is None:
            raise ViewerError("the whole volume is on show; use Save mesh")
        if self.exporting is not None:
            raise ViewerError("an export is still running; wait for it to finish")
        self._export = FullResolutionExport(state.full_volume, state.iso, path, state.gradient_direction,
                                            state.mesh_options.topology)
        return state.jobs.submit("export", self._export.wait, message=self._export.message,
                                 failure="the export's progress could not be read")

    @property
    def exporting(self):
        """The full-resolution export running (its `fraction` and `message`), or None."""
        return self._state.jobs.current("export")

    def exported(self, response: Response) -> None:
        """An "export" job's answer: its "wrote" message, or its error raised."""
        if response.error is not None:
            raise ViewerError(f"full-resolution export failed: {one_line(response.error)}")
        self._state.error, self._state.message = None, response.value

    def stop(self) -> None:
        """Stop a full-resolution export still running (its file is written whole or not at all)."""
        if self._export is not None:
            self._export.cancel()
