"""Background jobs with a request id in and a response out, as napari's slicing answers its requests.

A job runs on a worker thread (reading a volume: the window keeps drawing and shows its progress).
`submit` returns the request's id; the frame loop takes the finished responses from `poll`, each
carrying the id it was asked with.  A newer request of the same kind makes an older one stale:
its response, whenever it comes, is dropped, so a slow answer never overwrites a later one.
GL work is not done here: the GL context belongs to the main thread, which acts on the responses.
"""
from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from dataclasses import dataclass

from .errors import READ_ERRORS, ViewerError, one_line


@dataclass(frozen=True)
class Response:
    """A job's answer: its result, or the exception it raised (one-line message), never both."""
    request_id: int
    kind: str
    value: object = None
    error: Exception | None = None


class Job:
    """One request on its worker thread; `fraction` and `message` report its progress."""

    def __init__(self, request_id: int, kind: str, work: Callable, args: tuple, message: str, failure: str):
        self.request_id, self.kind = request_id, kind
        self.fraction, self.message = 0.0, message
        self.failure = failure          # the start of the one line for a bug in the work
        self.response: Response | None = None
        self._work, self._args = work, args
        self._thread: threading.Thread | None = None

    def start(self, inline: bool = False) -> None:
        """Run the work on a worker thread, or `inline` in this one."""
        if inline:
            self._run(self._work, self._args)
        else:
            self._thread = threading.Thread(target=self._run, args=(self._work, self._args), daemon=True,
                                            name=f"isoscope {self.kind} {self.request_id}")
            self._thread.start()

    def _run(self, work: Callable, args: tuple) -> None:
        try:
            value = work(*args, progress=self.report)
        except READ_ERRORS as exc:
            self.response = Response(self.request_id, self.kind, error=exc)
        except Exception as exc:  # a bug in the work must not take the viewer down with it
            error = ViewerError(f"{self.failure}: {type(exc).__name__}: {one_line(exc)[:200]}")
            self.response = Response(self.request_id, self.kind, error=error)
        else:
            self.response = Response(self.request_id, self.kind, value=value)

    def report(self, fraction: float, message: str) -> None:
        """Record the job's progress (0..1) and what it is doing; the worker's `progress` callback, read by the frame
        loop."""
        self.fraction, self.message = float(fraction), message

    def done(self, wait_s: float = 0.0) -> bool:
        """Whether the work has finished, after waiting up to `wait_s` seconds for it; a job run inline is always done.
        """
        if self._thread is None:   # run inline (the work is done)
            return True
        self._thread.join(wait_s)
        return not self._thread.is_alive()


class Jobs:
    """The viewer's background jobs: `submit` work, `poll` for the answers that are still wanted."""

    def __init__(self):
        self._ids = itertools.count(1)
        self._latest: dict[str, int] = {}    # kind -> the id of its newest request
        self._running: list[Job] = []

    def submit(self, kind: str, work: Callable, *args, message: str = "", failure: str = "",
               inline: bool = False) -> int:
        """Run `work(*args, progress=report)` on a worker thread (with `inline`, in this one, for work
        that needs the caller's GL context); the request's id.  An earlier request of the same `kind`
        still running becomes stale.  `failure` starts the one line of an unexpected exception."""
        job = Job(next(self._ids), kind, work, args, message or kind, failure or f"{kind} failed")
        self._latest[kind] = job.request_id
        self._running.append(job)
        job.start(inline)
        return job.request_id

    def current(self, kind: str) -> Job | None:
        """The newest request of `kind` until its answer is taken by `poll` (for a progress bar), else None."""
        for job in self._running:
            if job.request_id == self._latest.get(kind):
                return job
        return None

    def is_current(self, response: Response) -> bool:
        """Whether `response` answers the latest request of its kind (an older one is stale and is dropped)."""
        return self._latest.get(response.kind) == response.request_id

    def poll(self, wait_s: float = 0.0) -> list[Response]:
        """The responses that came in since the last poll (waiting up to `wait_s` for the current
        requests), oldest request first; stale ones are dropped."""
        for job in self._running:
            if self._latest.get(job.kind) == job.request_id:
                job.done(wait_s)
        finished = [job for job in self._running if job.response is not None]
        self._running = [job for job in self._running if job.response is None]
        return [job.response for job in finished if self.is_current(job.response)]
