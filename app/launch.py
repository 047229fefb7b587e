"""The `isoscope` command's entry point: a Ctrl-C at any moment, also while the command's modules import
or its arguments are read (before `cli.main`'s own handling is in place), ends it with exit 130 and no
traceback."""
from __future__ import annotations

import sys
import threading


def main() -> int:
    """The command's entry point: import and run `cli.main` with Ctrl-C held off during the imports; exit status 130 on
    Ctrl-C, with no traceback."""
    sys.unraisablehook = _interrupt_again
    try:
        from .io.atomic import signals_deferred
        # A Ctrl-C inside a C extension's start (numpy's, as the command's modules import) comes out as
        # an ImportError with a page of advice: the imports run with it held off, and it acts after them.
        with signals_deferred():
            from .cli.main import main as run
        return run()
    except KeyboardInterrupt:
        return 130


_interrupted = threading.Event()


def _interrupt_again(unraisable) -> None:
    """A Ctrl-C that lands where Python cannot raise it (importlib's module-lock callback, a garbage
    collector callback of dask's) would print "Exception ignored in ..." and be lost: it is raised again
    in the main thread, from another thread so that it arrives after this hook, not inside it. What
    such an interrupted callback leaves broken (dask's gc timer asserts next time) is not printed
    either: the command is on its way out with 130."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and not _interrupted.is_set():
        import _thread
        _interrupted.set()
        later = threading.Timer(0.05, _thread.interrupt_main)  # once this hook (and Thread.start) returned
        later.daemon = True
        later.start()
        return
    if not _interrupted.is_set():
        sys.__unraisablehook__(unraisable)
