"""The file browser drawn inside the window where the desktop has no dialog tool (issue 26): it lists a
folder (folders first, the volumes' patterns), marks a DICOM series, and a click on its rows opens the
file or the folder, driven through imgui's own mouse input in the panel of a headless viewer.
"""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.viewer.model.recent import RecentFiles
from isoscope.viewer.ui.file_browser import FileBrowser, is_dicom_folder

SIZE = (1024, 700)


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "series").mkdir()
    (tmp_path / "Zeta").mkdir()
    (tmp_path / ".hidden").mkdir()
    ball = (np.sqrt(((np.indices((16, 16, 16)) - 7.5) ** 2).sum(axis=0)) < 5).astype(np.float32)
    np.save(tmp_path / "ball.npy", ball)
    (tmp_path / "notes.txt").write_text("not a volume")
    return tmp_path


def write_dicom(folder):
    from support.dicom_series import write_series
    write_series(folder, [np.full((6, 5), 100 * k, np.int16) for k in range(4)])


def test_a_folder_is_listed_folders_first_with_the_patterns(folder):
    write_dicom(folder / "series")
    browser = FileBrowser()
    browser.open_file("Open volume", folder, ["*.npy", "*.nii.gz"])
    entries = browser.entries()
    assert [(e.name, e.is_folder) for e in entries] == [("series", True), ("Zeta", True), ("ball.npy", False)]
    assert [e.dicom for e in entries] == [True, False, False]
    assert is_dicom_folder(folder / "series") and not is_dicom_folder(folder)


def test_choosing_walks_folders_and_answers_once(folder, tmp_path_factory):
    recent = RecentFiles(tmp_path_factory.mktemp("config") / "recent_folders.json")
    browser = FileBrowser(recent)
    browser.open_file("Open volume", folder / "Zeta", ["*.npy"])
    browser.up()
    assert browser.folder == folder.resolve()
    browser.choose("Zeta")       # a folder: entered, no answer
    assert browser.folder == (folder / "Zeta").resolve() and browser.take() is None
    browser.up()
    browser.choose("ball.npy")
    assert browser.take() == str(folder.resolve() / "ball.npy") and browser.take() is None
    assert not browser.is_open and recent.paths == [str(folder.resolve())]
    browser.open_file("Open volume", folder, ["*.npy"])
    browser.file_name = "missing.npy"
    browser.confirm()
    assert browser.is_open and "no file missing.npy" in browser.error
    browser.enter(folder / "nowhere")
    assert "cannot list" in browser.error and browser.folder == folder.resolve()


def test_save_takes_a_typed_name_in_the_folder_shown(folder):
    browser = FileBrowser()
    browser.save_file("Save mesh", folder / "mesh.stl", ["*.stl"], purpose="save mesh")
    assert browser.folder == folder.resolve() and browser.file_name == "mesh.stl"
    browser.choose("series")
    browser.file_name = "head.ply"
    browser.confirm()
    assert browser.take() == str((folder / "series").resolve() / "head.ply") and browser.purpose == "save mesh"


# --- in the panel, clicked with imgui's mouse ------------------------------------------------------------------
@pytest.fixture
def viewer(gl_ctx, monkeypatch, tmp_path_factory):
    """A headless viewer whose panel has no native dialog (as on a desktop with no zenity or kdialog)."""
    import isoscope.viewer.ui.panel as panel_module
    from isoscope.viewer.ui.headless import HeadlessViewer
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.mktemp("config")))
    monkeypatch.setattr(panel_module, "has_dialog_tool", lambda: False)
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    viewer._panel.can_browse = True
    viewer.open("sphere")
    yield viewer
    viewer.release()


def click(viewer, box, double: bool = False):
    """Move imgui's mouse to the middle of `box` and click (twice for `double`), a frame per event."""
    from isoscope.viewer.ui.gui import imgui
    (left, top), (right, bottom) = box
    io = imgui.get_io()
    io.add_mouse_pos_event((left + right) / 2, (top + bottom) / 2)
    viewer.render(panel=True)
    for _ in range(2 if double else 1):
        io.add_mouse_button_event(0, True)
        viewer.render(panel=True)
        io.add_mouse_button_event(0, False)
        viewer.render(panel=True)


def opened_name(viewer, frames=200):
    for _ in range(frames):
        viewer.render(panel=True)
        if viewer.state.opening.loading is None:
            break
    return viewer.state.volume.name


def test_clicking_a_file_in_the_panel_s_browser_opens_it(viewer, folder, monkeypatch):
    monkeypatch.chdir(folder)
    panel = viewer._panel
    viewer.render(panel=True)
    panel._open_file_dialog(viewer.state)
    viewer.render(panel=True)
    browser = panel.browser
    assert browser.is_open and list(browser.entry_boxes) == ["series", "Zeta", "ball.npy"]
    click(viewer, browser.entry_boxes["ball.npy"], double=True)
    assert not browser.is_open
    assert opened_name(viewer) == "ball.npy"
    assert viewer.state.volume.data.shape == (16, 16, 16)


def test_a_dicom_folder_opens_from_the_browser(viewer, folder, monkeypatch):
    write_dicom(folder / "series")
    monkeypatch.chdir(folder)
    panel = viewer._panel
    viewer.render(panel=True)
    panel._open_file_dialog(viewer.state)
    viewer.render(panel=True)
    click(viewer, panel.browser.entry_boxes["series"])     # a folder: one click enters it
    assert panel.browser.folder == (folder / "series").resolve()
    panel.browser.choose_folder()                         # the "Open this folder" button's act
    assert opened_name(viewer) != "sphere"
    assert sorted(viewer.state.volume.data.shape) == [4, 5, 6]   # the series: 4 slices of 6 x 5


def test_save_scene_goes_through_the_browser_and_writes_the_scene(viewer, folder, monkeypatch):
    import isoscope.viewer.ui.measure_panel as measure_panel
    from isoscope.viewer.model.scene_file import read_scene
    monkeypatch.setattr(measure_panel, "has_dialog_tool", lambda: False)
    monkeypatch.chdir(folder)
    section = viewer._panel.measure_section
    viewer.render(panel=True)
    section._open_scene_dialog(viewer.state)   # the "Save scene..." button's act
    viewer.render(panel=True)
    browser = section.browser
    assert browser.is_open and browser.saving and browser.file_name == "sphere-scene.json"
    click(viewer, browser.entry_boxes["series"])   # into a folder, then Save
    browser.confirm()
    viewer.render(panel=True)
    written = folder / "series" / "sphere-scene.json"
    scene = read_scene(written)
    assert scene["volume"]["source"] == "sphere" and scene["size"] == list(SIZE)
    assert viewer.state.message == f"scene saved: {written.resolve()}"
