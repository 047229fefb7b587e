"""The one way in for every path a user names that isoscope reads whole (label tables, scenes, sidecars) or
hands to a loader (volumes, colour-by volumes, a pattern's members): regular files only, their size capped
before a byte is read, and every message naming the user's path with its control characters escaped.

A FIFO would block a read forever, /dev/zero would fill memory, a 2 GB "label table" would take minutes; a
file name carrying ESC or BEL bytes would clear the user's terminal or retitle it when echoed, and one with
a newline would split an error in two.  So: `shown(path)` is how a path is written in any message, and
`regular_file` / `read_bytes` / `read_text` refuse what is not a file of a sensible size, in one line.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import InputError


class UnreadablePath(InputError):
    """A path a user named that is not there, not a regular file, too big for what it should be, or unreadable."""


def shown(text) -> str:
    """`text` (a path, a name from a file) fit to print on one line: control characters (C0, DEL, C1) and
    lone surrogates written as escapes (\\x1b, \\n), everything else as it is."""
    out = []
    for char in str(text):
        code = ord(char)
        if code < 0x20 or 0x7F <= code < 0xA0 or 0xD800 <= code < 0xE000:
            out.append({"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(char, f"\\x{code:02x}" if code < 0x100
                                                                           else f"\\u{code:04x}"))
        else:
            out.append(char)
    return "".join(out)


def kind_of(mode: int) -> str:
    """What a non-regular file is, in words."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a device"


def regular_file(path, what: str = "the file", max_bytes: int | None = None, empty_ok: bool = True) -> Path:
    """`path` (~ expanded) if it names a regular file (a link to one counts) of at most `max_bytes` (and, unless
    `empty_ok`, not empty); else UnreadablePath in one line naming `what` and the path.  Nothing is opened: a
    FIFO is refused without blocking, a device without a read."""
    path = Path(os.path.expanduser(str(path)))
    try:
        st = path.stat()
    except OSError as exc:
        reason = "is not there" if isinstance(exc, FileNotFoundError) else f"cannot be read ({exc.strerror or exc})"
        raise UnreadablePath(f"{what} {shown(path)} {reason}; check the path") from None
    if not stat.S_ISREG(st.st_mode):
        raise UnreadablePath(f"{what} {shown(path)} is {kind_of(st.st_mode)}, not a regular file; "
                             "save the data to a file and name that")
    if not empty_ok and st.st_size == 0:
        raise UnreadablePath(f"{what} {shown(path)} is empty (0 bytes): cut off while copying or saving? Copy or "
                             "export it again")
    if max_bytes is not None and st.st_size > max_bytes:
        raise UnreadablePath(f"{what} {shown(path)} is {st.st_size:,} bytes, more than one can be "
                             f"({max_bytes:,}); is it the right file?")
    return path


def read_bytes(path, what: str, max_bytes: int) -> bytes:
    """The whole of the regular file `path`, at most `max_bytes` (also if it grows while read)."""
    path = regular_file(path, what, max_bytes)
    try:
        with open(path, "rb") as stream:
            data = stream.read(max_bytes + 1)
    except OSError as exc:
        raise UnreadablePath(f"{what} {shown(path)} cannot be read ({exc.strerror or exc}); check the path and "
                             "its permissions") from None
    if len(data) > max_bytes:
        raise UnreadablePath(f"{what} {shown(path)} grew past {max_bytes:,} bytes while being read; is it the "
                             "right file?")
    return data


def read_text(path, what: str, max_bytes: int, errors: str = "strict") -> str:
    """`read_bytes` as UTF-8 text (a BOM dropped); undecodable bytes refused in one line (or replaced, with
    errors="replace")."""
    data = read_bytes(path, what, max_bytes)
    try:
        return data.decode("utf-8-sig", errors=errors)
    except UnicodeDecodeError as exc:
        raise UnreadablePath(f"{what} {shown(path)} is not UTF-8 text (byte {exc.start}); is it the right "
                             "file?") from None
