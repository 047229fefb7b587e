"""The `isoscope` command's entry point: a Ctrl-C at any moment, also while the command's modules import
or its arguments are read (before `cli.main`'s own handling is in place), ends it with exit 130 and no
traceback."""
from __future__ import annotations

import sys


def main() -> int:
    sys.unraisablehook = _interrupt_again
    try:
        from .atomic import signals_deferred
        # A Ctrl-C inside a C extension's start (numpy's, as the command's modules import) comes out as
        # an ImportError with a page of advice: the imports run with it held off, and it acts after them.
        with signals_deferred():
            from .cli import main as run
        return run()
    except KeyboardInterrupt:
        return 130


def _interrupt_again(unraisable) -> None:
    """A Ctrl-C that lands in a callback Python cannot raise from (importlib's module-lock cleanup during
    an import) would print "Exception ignored in ..." and be lost: raise it again in the main thread."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        import _thread
        _thread.interrupt_main()
        return
    sys.__unraisablehook__(unraisable)
