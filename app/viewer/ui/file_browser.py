"""A file browser drawn inside the window, for desktops with no dialog tool (zenity, kdialog): Open file,
Save mesh, Save scene.

imgui-bundle's ImFileDialog cannot serve: its `open` asserts "CreateTexture function pointer is not set"
(its icons' texture callback, which only hello_imgui's runner installs and Python cannot set), and
portable-file-dialogs runs zenity or kdialog; this one is plain imgui:
a folder's entries (folders first), a path to type, the parent, home and recent folders, a file name to
save as.  A folder holding a DICOM series is marked and can be chosen itself ("Open this folder").
`open_file`/`save_file` start it; `draw` once a frame returns the chosen path once (None meanwhile).
The choosing is also callable (`enter`, `select`, `choose`, `choose_folder`, `confirm`), as a click does.
"""
from __future__ import annotations

import os
import shutil
import sys
from dataclasses import dataclass
from fnmatch import fnmatch
from pathlib import Path

from ..model.recent import RecentFiles
from .gui import imgui, tooltip

LINUX_DIALOG_TOOLS = ("zenity", "kdialog", "qarma", "matedialog")
BROWSER_TITLE = "Choose a file##isoscope browser"
BROWSER_SIZE = (600.0, 430.0)
MAX_ENTRIES = 2000          # a folder of 100,000 DICOM slices is listed in part, and says so
DICOM_SNIFF = 4             # files read (132 bytes each) to tell a DICOM folder
ERROR_COLOR = imgui.ImVec4(1.0, 0.45, 0.40, 1.0)
FOLDER_COLOR = imgui.ImVec4(0.55, 0.75, 1.0, 1.0)


def has_dialog_tool() -> bool:
    """Whether portable-file-dialogs has a native dialog here (always on macOS and Windows; on Linux it
    runs one of LINUX_DIALOG_TOOLS)."""
    return not sys.platform.startswith("linux") or any(shutil.which(tool) for tool in LINUX_DIALOG_TOOLS)


def is_dicom_folder(folder: Path) -> bool:
    """A folder of DICOM files: a DICOMDIR, *.dcm files, or files with DICOM's 'DICM' at byte 128."""
    try:
        with os.scandir(folder) as entries:
            files = [entry for _, entry in zip(range(64), (e for e in entries if e.is_file()))]
    except OSError:
        return False
    if any(entry.name.upper() == "DICOMDIR" or entry.name.lower().endswith(".dcm") for entry in files):
        return True
    for entry in files[:DICOM_SNIFF]:
        try:
            with open(entry.path, "rb") as file:
                if file.read(132)[128:] == b"DICM":
                    return True
        except OSError:
            continue
    return False


@dataclass(frozen=True)
class Entry:
    """One row of the browser: a file or folder name, and whether a folder holds a DICOM series."""
    name: str
    is_folder: bool
    dicom: bool = False


def patterns_of(filters) -> list[str]:
    """The first group's patterns of a portable-file-dialogs filter list ["Volumes", "*.npy *.nii", ...]."""
    return filters[1].split() if len(filters) >= 2 else ["*"]


class FileBrowser:
    """See the module's docstring."""

    def __init__(self, recent_folders: RecentFiles | None = None):
        self.recent_folders = recent_folders if recent_folders is not None else RecentFiles(None)
        self.is_open = False
        self.saving = False
        self.title = ""
        self.purpose = ""            # what the caller will do with the answer ("open", "save", ...)
        self.suggested: list[str] = []
        self.folder = Path.cwd()
        self.patterns: list[str] = ["*"]
        self.file_name = ""          # selected (open) or typed (save)
        self.path_text = ""
        self.error: str | None = None
        self.truncated = False
        self._entries: list[Entry] | None = None
        self._result: str | None = None
        self._focus = False
        self.entry_boxes: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {}  # drawn rows, for tests

    # --- starting -----------------------------------------------------------------
    def open_file(self, title: str, folder, patterns=("*",), purpose: str = "open", folders=()) -> None:
        """Choose a file (or a DICOM folder) to open, from `folder`; `purpose` tags the answer for the
        caller; `folders` are offered beside the recent ones (the recent files' folders)."""
        self._start(title, folder, patterns, False, "", purpose, folders)

    def save_file(self, title: str, default_path, patterns=("*",), purpose: str = "save", folders=()) -> None:
        """Choose where to save, starting at `default_path` (its folder and name)."""
        default_path = Path(default_path)
        self._start(title, default_path.parent, patterns, True, default_path.name, purpose, folders)

    def _start(self, title, folder, patterns, saving: bool, file_name: str, purpose: str, folders) -> None:
        self.is_open, self.saving, self.title, self.purpose = True, saving, title, purpose
        self.patterns, self.file_name, self._result = list(patterns) or ["*"], file_name, None
        self.suggested = [str(f) for f in folders]
        self._focus = True
        if not self.enter(folder):
            self.enter(Path.cwd())

    def cancel(self) -> None:
        """Close the browser without choosing."""
        self.is_open = False

    # --- choosing (what the clicks do) -------------------------------------------------
    def enter(self, folder) -> bool:
        """Show `folder`'s entries; an unreadable one keeps the folder shown and says why."""
        folder = Path(folder).expanduser()
        if not folder.is_absolute():
            folder = self.folder / folder
        folder = folder.resolve()
        try:
            entries = self._list(folder)
        except OSError as exc:
            self.error = f"cannot list {folder}: {exc.strerror or exc}"
            return False
        self.folder, self._entries, self.error = folder, entries, None
        self.path_text = str(folder)
        return True

    def up(self) -> None:
        """List the parent folder."""
        self.enter(self.folder.parent)

    def entries(self) -> list[Entry]:
        """The rows of the folder on show (listed on first use); empty where it cannot be read."""
        if self._entries is None:
            self.enter(self.folder)
        return self._entries or []

    def select(self, name: str) -> None:
        """A click on an entry: a folder is entered, a file's name is selected (Open/Save then take it)."""
        target = self.folder / name
        if target.is_dir():
            self.enter(target)
        else:
            self.file_name = name

    def choose(self, name: str) -> None:
        """A double click: a folder is entered, a file is the answer."""
        self.select(name)
        if not (self.folder / name).is_dir():
            self.confirm()

    def choose_folder(self) -> None:
        """The folder shown is the answer (a DICOM series)."""
        self._finish(self.folder)

    def confirm(self) -> None:
        """Open or Save: the selected or typed file name in the folder shown (a typed path is taken as it is)."""
        name = self.file_name.strip()
        if not name:
            self.error = "type a file name" if self.saving else "select a file, or open the folder"
            return
        path = Path(name).expanduser()
        path = path if path.is_absolute() else self.folder / path
        if path.is_dir():
            self.enter(path)
            self.file_name = ""
            return
        if not self.saving and not path.is_file():
            self.error = f"no file {path.name} in {path.parent}"
            return
        if self.saving and not path.parent.is_dir():
            self.error = f"no folder {path.parent}"
            return
        self._finish(path)

    def take(self) -> str | None:
        """The answer, once (None until there is one)."""
        result, self._result = self._result, None
        return result

    def _finish(self, path: Path) -> None:
        self.recent_folders.add(str(path if path.is_dir() else path.parent))
        self._result, self.is_open, self.error = str(path), False, None

    def _list(self, folder: Path) -> list[Entry]:
        folders, files = [], []
        with os.scandir(folder) as scan:
            for n, entry in enumerate(scan):
                if n >= MAX_ENTRIES * 4:
                    break
                if entry.name.startswith("."):
                    continue
                try:
                    is_folder = entry.is_dir()
                except OSError:
                    continue
                if is_folder:
                    folders.append(entry.name)
                elif any(fnmatch(entry.name.lower(), pattern) for pattern in self.patterns):
                    files.append(entry.name)
        listed = sorted(folders, key=str.lower) + sorted(files, key=str.lower)
        self.truncated = len(listed) > MAX_ENTRIES
        named = set(folders)
        return [Entry(name, name in named, name in named and is_dicom_folder(folder / name))
                for name in listed[:MAX_ENTRIES]]

    # --- drawing ----------------------------------------------------------------
    def draw(self) -> str | None:
        """Lay the browser out (while it is open); the chosen path, once."""
        if not self.is_open:
            return self.take()
        display = imgui.get_io().display_size
        imgui.set_next_window_size(imgui.ImVec2(*BROWSER_SIZE), imgui.Cond_.appearing)
        imgui.set_next_window_pos(imgui.ImVec2(display.x / 2, display.y / 2), imgui.Cond_.appearing,
                                  imgui.ImVec2(0.5, 0.5))
        if self._focus:
            imgui.set_next_window_focus()
            self._focus = False
        visible, still_open = imgui.begin(f"{self.title}###isoscope browser", True)
        if visible:
            self._draw_contents()
        imgui.end()
        if not still_open:
            self.cancel()
        return self.take()

    def _draw_contents(self) -> None:
        if imgui.button("Up"):
            self.up()
        imgui.same_line()
        if imgui.button("Home"):
            self.enter(Path.home())
        imgui.same_line()
        imgui.set_next_item_width(160)
        recent = list(dict.fromkeys(self.recent_folders.paths + self.suggested))
        if recent and imgui.begin_combo("##recent folders", "recent folders"):
            for folder in recent:
                if imgui.selectable(folder, False)[0]:
                    self.enter(folder)
            imgui.end_combo()
        imgui.set_next_item_width(-1)
        entered, self.path_text = imgui.input_text("##path", self.path_text, imgui.InputTextFlags_.enter_returns_true)
        if entered:
            typed = Path(self.path_text).expanduser()
            if typed.is_dir():
                self.enter(typed)
            else:
                self.file_name = str(typed)
                self.confirm()
        footer = imgui.get_frame_height_with_spacing() * (3 if self.saving else 2)
        imgui.begin_child("##entries", imgui.ImVec2(0, -footer), imgui.ChildFlags_.borders)
        self.entry_boxes = {}
        for entry in self.entries():
            label = f"{entry.name}/" + ("   [DICOM series]" if entry.dicom else "") if entry.is_folder else entry.name
            if entry.is_folder:
                imgui.push_style_color(imgui.Col_.text, FOLDER_COLOR)
            clicked, _ = imgui.selectable(f"{label}##{entry.name}", entry.name == self.file_name,
                                          imgui.SelectableFlags_.allow_double_click)
            if entry.is_folder:
                imgui.pop_style_color()
            self.entry_boxes[entry.name] = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
            if clicked:
                if imgui.is_mouse_double_clicked(0) and not entry.is_folder:
                    self.choose(entry.name)
                else:
                    self.select(entry.name)
                break   # the entries may have changed (a folder entered)
        if self.truncated:
            imgui.text_disabled(f"(the first {MAX_ENTRIES:,} entries)")
        imgui.end_child()
        if self.saving:
            imgui.set_next_item_width(-1)
            typed, self.file_name = imgui.input_text("##file name", self.file_name,
                                                     imgui.InputTextFlags_.enter_returns_true)
            if typed:
                self.confirm()
        if imgui.button("Save" if self.saving else "Open"):
            self.confirm()
        if not self.saving:
            imgui.same_line()
            if imgui.button("Open this folder"):
                self.choose_folder()
            tooltip("a DICOM series: the folder of its slices")
        imgui.same_line()
        if imgui.button("Cancel"):
            self.cancel()
        if self.error:
            imgui.same_line()
            imgui.text_colored(ERROR_COLOR, self.error)
        elif not self.saving and self.file_name:
            imgui.same_line()
            imgui.text_disabled(self.file_name)


def default_recent_folders() -> RecentFiles:
    """The browser's recent folders, kept beside the recent files' list."""
    return RecentFiles(RecentFiles.default_path().with_name("recent_folders.json"))
