"""The one base of every exception isoscope defines: `except isoscope.IsoscopeError` catches what the
package raises on purpose, and nothing else. Each subclass keeps the built-in base its callers relied on
before (ValueError for bad input, RuntimeError for a missing platform), as a second base."""
from __future__ import annotations


class IsoscopeError(Exception):
    """Raised by isoscope on purpose: its message is one line, naming the problem and the fix."""


class InputError(IsoscopeError, ValueError):
    """A value a caller gave (an array, a level, an option, a size) that the call cannot take: one line naming
    it and the fix.  A ValueError too, as bad input always was."""


class MissingPackage(IsoscopeError, ImportError):
    """An optional package a call needs is not installed: the message names it and the pip line that brings it."""


class ReleasedError(IsoscopeError, RuntimeError):
    """An object used after its `release()` (or its ``with`` block's end): its memory is gone; make a new one."""
