"""The one base of every exception isoscope defines: `except isoscope.IsoscopeError` catches what the
package raises on purpose, and nothing else. Each subclass keeps the built-in base its callers relied on
before (ValueError for bad input, RuntimeError for a missing platform), as a second base."""
from __future__ import annotations


class IsoscopeError(Exception):
    """Raised by isoscope on purpose: its message is one line, naming the problem and the fix."""
