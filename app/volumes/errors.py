"""The one exception type every bad volume input becomes."""
from __future__ import annotations

from ..errors import IsoscopeError


class VolumeError(IsoscopeError, ValueError):
    """One-line, user-facing: names the problem and the fix.

    The CLI prints str(err) and exits 2; the viewer panel shows it and keeps
    the last good volume. Never carries a traceback's worth of text.
    """

    def __init__(self, message: str):
        # Keep the promise of one line even when a library's message had newlines in it.
        super().__init__(" ".join(str(message).split()))
