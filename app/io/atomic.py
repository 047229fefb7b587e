"""Write a file so that a failure never leaves half of it, nor harms the file it replaces.

Also when the process is told to stop part-way: while `write_atomically` runs on the main thread,
SIGINT and SIGTERM are only noted; the temporary file is then removed, never renamed into place, and
the signal handed on to what handled it before (SIGINT: KeyboardInterrupt, the command exits 130;
SIGTERM: the process ends by the signal, 143 in a shell). `signals_not_swallowed` keeps code that
catches BaseException (trimesh's encoders) from hiding an interrupt.
"""
from __future__ import annotations

import errno
import os
import signal
import stat
import tempfile
import threading
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def current_umask() -> int:
    """The process's umask, read without changing it where Linux says it (/proc/self/status is
    thread-safe); elsewhere by setting and restoring it."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o077)
    os.umask(mask)
    return mask


@contextmanager
def _held():
    """SIGINT and SIGTERM held back while handlers are swapped, so that none arrives half-way
    (a Python handler raising between two swaps); they arrive, to the new handlers, as it ends."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


class _Signals:
    """SIGINT and SIGTERM noted while a block runs on the main thread; the first one received is
    handed on to the previous handlers when the block ends (or at once, with `defer=False`)."""

    def __init__(self, defer: bool):
        self.defer = defer
        self.received: int | None = None
        self.previous: dict[int, object] = {}

    def install(self) -> None:
        """Note SIGINT and SIGTERM from here on (signals ignored, or not set from Python, are left alone), keeping the
        handlers there were."""
        with _held():
            for signum in STOP_SIGNALS:
                before = signal.getsignal(signum)
                if before in (signal.SIG_IGN, None):  # ignored (nohup, a background job), or not set from Python
                    continue
                self.previous[signum] = before
                signal.signal(signum, self._handler)

    def restore(self) -> None:
        """Put back the handlers there were before `install`."""
        with _held():
            for signum, before in self.previous.items():
                signal.signal(signum, before)

    def _handler(self, signum, frame) -> None:
        if self.received is None:
            self.received = signum
        if not self.defer:  # every time: a second Ctrl-C in a block that swallowed the first acts too
            self._hand_on(signum, frame)

    def _hand_on(self, signum, frame) -> None:
        """What would have happened without us: the previous Python handler called (SIGINT's raises
        KeyboardInterrupt), or the default action (SIGTERM: the process ends, skipping no file of ours)."""
        before = self.previous.get(signum, signal.SIG_DFL)
        if callable(before):
            before(signum, frame)
            return
        signal.signal(signum, signal.SIG_DFL)
        signal.raise_signal(signum)

    def deliver(self) -> None:
        """After `restore`: act on the signal noted, if any. Does not return after one. Python's own
        SIGINT handler raises KeyboardInterrupt and the default actions end the process; a handler of
        the caller's that returns has chosen to carry on, so the process is not ended for it, but the
        guarded work was cut short all the same: InterruptedError says so."""
        if self.received is None:
            return
        signum = self.received
        self._hand_on(signum, None)
        raise InterruptedError(errno.EINTR, f"{signal.Signals(signum).name} arrived while writing; nothing was written")


def _on_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def signals_not_swallowed():
    """Run a block that may catch BaseException (and so swallow KeyboardInterrupt): SIGINT and
    SIGTERM act at once as usual, and if the block still returns normally after one, it is
    handed on again as it ends, so an interrupted computation's result is never used.
    Off the main thread (where handlers cannot be set) the block just runs."""
    if not _on_main_thread():
        yield
        return
    guard = _Signals(defer=False)
    try:
        guard.install()
        yield
    finally:
        guard.restore()
    guard.deliver()   # reached only when the block returned normally: the signal was swallowed in it


@contextmanager
def signals_deferred():
    """SIGINT and SIGTERM only noted while the block runs (main thread); yields the noter, whose
    `received` the block checks; on leaving, the previous handlers back and the signal handed on."""
    guard = _Signals(defer=True)
    if not _on_main_thread():
        yield guard
        return
    try:
        guard.install()
        yield guard
    finally:
        guard.restore()
        guard.deliver()


def _replaced(target: str):
    """os.stat of the regular file `target` names, or None when there is none."""
    try:
        st = os.stat(target)
    except OSError:
        return None
    return st if stat.S_ISREG(st.st_mode) else None


def _take_over(handle: int, temporary: str, replaced) -> None:
    """Give the temporary file the replaced file's permission bits (and, where allowed, its owner and
    group), or a new file's: 0666 & ~umask (mkstemp makes it 0600)."""
    if replaced is not None and hasattr(os, "fchown"):
        uid = replaced.st_uid if os.geteuid() == 0 else -1   # only root may give a file away
        if (uid, replaced.st_gid) != (-1, os.getegid()):
            try:
                os.fchown(handle, uid, replaced.st_gid)
            except OSError:
                pass  # not one of our groups: the file is ours, as any new file would be
    mode = stat.S_IMODE(replaced.st_mode) & 0o777 if replaced is not None else 0o666 & ~current_umask()
    if hasattr(os, "fchmod"):
        os.fchmod(handle, mode)
    else:
        os.chmod(temporary, mode)


def _write_in_place(path: Path, write: Callable[[BinaryIO], object]) -> Path:
    try:
        with open(path, "wb") as out:
            write(out)
    except OSError as exc:
        if exc.filename is None:
            exc.filename = str(path)
        raise
    return path


def write_atomically(path, write: Callable[[BinaryIO], object]) -> Path:
    """Call `write` on a temporary file beside `path`, flush it to disk, then rename it over `path`.

    If anything fails, or SIGINT/SIGTERM arrives, the temporary file is removed and `path` is as it
    was. A `path` that is a symbolic link is written through (its target replaced, the link kept);
    one that is a device or a pipe (/dev/null, /dev/stdout, a FIFO) is written into, not replaced.
    The file gets the permissions (and where allowed the owner and group) of the file it replaces,
    or those of a new file under the umask.
    An OSError names `path`, never the temporary file."""
    path = Path(path)
    try:
        existing = os.stat(path)
    except OSError:
        existing = None
    if existing is not None and not (stat.S_ISREG(existing.st_mode) or stat.S_ISDIR(existing.st_mode)):
        # a device, pipe or socket (/dev/null, /dev/stdout, a FIFO): written into where it is, as
        # `open` would; renaming over it would put a regular file in its place (as root, /dev/null's)
        return _write_in_place(path, write)
    target = os.path.realpath(path)
    directory, name = os.path.split(target)
    try:
        with signals_deferred() as signals:
            replaced = _replaced(target)
            handle, temporary = tempfile.mkstemp(dir=directory or ".", prefix=f".{name}.", suffix=".partial")
            try:
                with os.fdopen(handle, "wb") as out:
                    _take_over(out.fileno(), temporary, replaced)
                    write(out)
                    out.flush()
                    os.fsync(out.fileno())
                if signals.received is not None:  # told to stop: the file must not take the user's name
                    os.unlink(temporary)
                else:
                    os.replace(temporary, target)
            except BaseException:
                try:
                    os.unlink(temporary)
                except OSError:
                    pass
                raise
    except OSError as exc:
        named = exc.filename if isinstance(exc.filename, str) else None
        if named is None or named in (target, directory) or (
                os.path.basename(named).startswith(f".{name}.") and named.endswith(".partial")):
            exc.filename = str(path)
        if exc.filename2 is not None:
            exc.filename2 = None
        raise
    return path
