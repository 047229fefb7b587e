"""The files a user opened, newest first, kept across sessions."""
from __future__ import annotations

import json
import os
from pathlib import Path

MAX_RECENT = 8


class RecentFiles:
    """Files the user opened, newest first, kept in a small JSON file across sessions."""

    def __init__(self, path: Path | None):
        self.path = path
        self.paths: list[str] = []
        if path is not None:
            try:
                loaded = json.loads(Path(path).read_text())
                self.paths = [p for p in loaded if isinstance(p, str)][:MAX_RECENT]
            except (OSError, ValueError):
                pass  # no history yet, or an unreadable one: start afresh

    @staticmethod
    def default_path() -> Path:
        """Where the list lives: isoscope/recent.json in $XDG_CONFIG_HOME (default ~/.config)."""
        config = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
        return Path(config) / "isoscope" / "recent.json"

    def add(self, path: str) -> None:
        """Put `path` (made absolute) first in the list, without repeats, keeping the most recent `MAX_RECENT`, and
        write the list; a file that cannot be written is skipped (a read-only home does not stop the viewer)."""
        path = str(Path(path).resolve())
        self.paths = [path] + [p for p in self.paths if p != path][:MAX_RECENT - 1]
        if self.path is not None:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self.path.write_text(json.dumps(self.paths, indent=1))
            except OSError:
                pass  # a read-only home must not stop the viewer
