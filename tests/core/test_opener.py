"""The one opener (core/opener.py): regular files only, size capped before a read, paths shown with control
characters escaped; a FIFO or /dev/zero is refused at once, not read."""
from __future__ import annotations

import os
import time

import pytest

import isoscope
from isoscope.core.opener import read_text, regular_file, shown


def test_control_characters_never_reach_the_terminal():
    assert shown("a\x1b]0;title\x07b\nc\x9bd") == "a\\x1b]0;title\\x07b\\nc\\x9bd"
    assert shown("ct_é.nii") == "ct_é.nii"


def test_pipes_devices_folders_and_missing_files_are_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    start = time.monotonic()
    for path, words in ((fifo, "named pipe"), ("/dev/zero", "device"), (tmp_path, "folder"),
                        (tmp_path / "gone.txt", "not there")):
        with pytest.raises(isoscope.IsoscopeError, match=words) as caught:
            read_text(path, "the table", 1000)
        assert "\n" not in str(caught.value) and isinstance(caught.value, ValueError)
    assert time.monotonic() - start < 5


def test_size_is_capped_before_reading_and_names_the_path_escaped(tmp_path):
    path = tmp_path / "big\x1b[2J.txt"
    path.write_bytes(b"x" * 2001)
    with pytest.raises(isoscope.IsoscopeError, match=r"2,001 bytes.*2,000") as caught:
        read_text(path, "the table", 2000)
    assert "\x1b" not in str(caught.value) and "\\x1b[2J" in str(caught.value)
    assert regular_file(path, "the table", 2001) == path
    assert read_text(path, "the table", 2001) == "x" * 2001
