"""What the panel remembers across runs: which of its sections are folded.  A small JSON file beside the
recent files' list (recent.py), written when a section is opened or folded."""
from __future__ import annotations

import json
from pathlib import Path

from .recent import RecentFiles

SETTINGS_VERSION = 1
SETTINGS_NAME = "panel.json"


class PanelSettings:
    """Which of the panel's sections are open, remembered in a JSON file across runs (or for this run only)."""

    def __init__(self, path: Path | None):
        """`path`: the JSON file (None: remembered for this run only).  A missing or unreadable file, or
        one of another version, starts afresh."""
        self.path = Path(path) if path is not None else None
        self.sections: dict[str, bool] = {}   # a section's title -> open; sections never touched keep their default
        if self.path is None:
            return
        try:
            loaded = json.loads(self.path.read_text())
        except (OSError, ValueError):
            return
        if isinstance(loaded, dict) and loaded.get("version") == SETTINGS_VERSION:
            sections = loaded.get("sections")
            if isinstance(sections, dict):
                self.sections = {str(k): bool(v) for k, v in sections.items() if isinstance(v, bool)}

    @staticmethod
    def beside(recent: RecentFiles) -> PanelSettings:
        """The settings kept beside `recent`'s file (none kept if it keeps none)."""
        return PanelSettings(Path(recent.path).parent / SETTINGS_NAME if recent.path is not None else None)

    def is_open(self, section: str, default: bool) -> bool:
        """Whether `section` is open: as the user left it, else `default`."""
        return self.sections.get(section, default)

    def set_open(self, section: str, is_open: bool) -> None:
        """Remember `section` open or folded, writing the file when that changes."""
        if self.sections.get(section) == is_open:
            return
        self.sections[section] = bool(is_open)
        self.save()

    def save(self) -> None:
        """Write the file (nothing without one); a file that cannot be written is skipped, as a read-only home must not
        stop the viewer."""
        if self.path is None:
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text(json.dumps({"version": SETTINGS_VERSION, "sections": self.sections}, indent=1))
        except OSError:
            pass  # a read-only home must not stop the viewer
