"""Reading a volume on a worker thread, and the one-line messages a bad volume becomes."""
from __future__ import annotations

import threading

import moderngl

from ...volumes import Volume, open_volume

# What a bad volume or extraction can raise: one-line messages meant for the user.
USER_ERRORS = (ValueError, OSError, moderngl.Error)


def one_line(exc: Exception) -> str:
    """The panel shows one line: GL driver errors (shader logs) come with several."""
    return " ".join(str(exc).split()) or type(exc).__name__


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
