"""What the viewer refuses, as exceptions: the model raises them, the panel shows their one line."""
from __future__ import annotations

from ...errors import IsoscopeError

READ_ERRORS = (ValueError, OSError)
"""What reading a bad volume raises on purpose: its message is meant for the user."""


class ViewerError(IsoscopeError, ValueError):
    """A change the viewer refuses (no such surface, a value outside the range, ...); the message
    names the problem and what to do instead."""


def one_line(exc: BaseException) -> str:
    """The panel shows one line: GL driver errors (shader logs) come with several."""
    return " ".join(str(exc).split()) or type(exc).__name__


USER_ERRORS = (IsoscopeError, ValueError, OSError)
"""What the state's changes raise on purpose (and a file that cannot be read or written): the panel
shows the one line and carries on."""
