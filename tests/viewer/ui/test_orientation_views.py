"""A scan opens in the same anatomical view whatever its storage order (issue 26): superior up, from anterior, as
3D Slicer's 3-D view; keys 1-6 and the View buttons look from the six standard directions.

The head (support/head_phantom.py) is one set of samples stored five ways: NIfTI RAS+ and LAS (a mirror
storage), and DICOM axial, coronal and sagittal series (every DICOM order is left-handed in LPS).  Its top
bump is superior, its nose anterior, its one ear on the patient's left, so a picture says which way is up
and whether it is mirrored.
"""
from __future__ import annotations

import numpy as np
import pytest
from support.head_phantom import LEVEL, write_dicom, write_nifti

from isoscope.viewer.model.camera import HOME_AZIMUTH, HOME_ELEVATION, ORBIT_LIMIT, VIEWS, OrbitCamera, volume_frame
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.viewer.ui.orientation import direction_letters, screen_letters
from isoscope.viewer.ui.view_panel import VIEW_KEYS, ViewSection, view_names
from isoscope.volumes import open_volume

STORAGES = ("nifti-RAS", "nifti-LAS", "dicom-axial", "dicom-coronal", "dicom-sagittal")
SIZE = (320, 240)

# Key -> (the side the eye is on, the letter at the screen's top, at its right), in Slicer's conventions:
# from the front the patient's left is on the right; from above and below anterior is up.
EXPECTED_VIEWS = {
    "1": ("A", "S", "L"), "2": ("P", "S", "R"), "3": ("L", "S", "P"),
    "4": ("R", "S", "A"), "5": ("S", "A", "R"), "6": ("I", "A", "L"),
}


@pytest.fixture(scope="module")
def heads(tmp_path_factory):
    """Storage name -> the path of the head stored that way."""
    folder = tmp_path_factory.mktemp("heads")
    paths = {"nifti-RAS": write_nifti(folder / "ras.nii.gz"), "nifti-LAS": write_nifti(folder / "las.nii.gz", "LAS")}
    for plane in ("axial", "coronal", "sagittal"):
        paths[f"dicom-{plane}"] = write_dicom(folder / plane, plane)
    return paths


def fitted_camera(volume) -> OrbitCamera:
    camera = OrbitCamera()
    upper = [(n - 1) * s for n, s in zip(volume.data.shape, volume.spacing)]
    camera.fit((0, 0, 0), upper, frame=volume_frame(volume))
    return camera


def view_letters(volume, camera) -> tuple[str, str, str]:
    """(the eye's side, the screen top's letter, the screen right's letter) in the patient."""
    matrix, space = volume.world
    to_world = np.asarray(matrix)[:3, :3] / np.asarray(volume.spacing)
    eye_side = direction_letters(to_world @ (camera.eye() - camera.target), space)
    letters = screen_letters(volume.world, volume.spacing, *camera.screen_axes())
    return eye_side, letters["top"], letters["right"]


# --- the camera (no GL) -----------------------------------------------------------------------------------

@pytest.mark.parametrize("storage", STORAGES)
def test_every_storage_order_opens_from_anterior_superior_up(heads, storage):
    volume = open_volume(str(heads[storage]))
    camera = fitted_camera(volume)
    assert view_letters(volume, camera) == ("A", "S", "L")
    # DICOM's (slice, row, column) and NIfTI's LAS are mirror images of the patient: the view mirrors them back.
    assert camera.mirrored == (storage != "nifti-RAS")


@pytest.mark.parametrize("storage", STORAGES)
def test_the_six_view_keys_look_from_the_six_sides(heads, storage):
    volume = open_volume(str(heads[storage]))
    camera = fitted_camera(volume)
    camera.zoom(2)
    camera.pan(30, -10, 400)
    keys = ViewSection().keys(camera)
    assert set(VIEW_KEYS) <= set(keys)
    target, distance = camera.target.copy(), camera.distance
    for key, expected in EXPECTED_VIEWS.items():
        keys[key]()
        assert view_letters(volume, camera) == expected, key
        # A view turns the camera; where it looks and how close stay.
        assert np.array_equal(camera.target, target) and camera.distance == distance
    camera.reset()
    assert view_letters(volume, camera) == ("A", "S", "L")


def test_without_a_patient_frame_the_views_are_the_array_axes_and_the_home_view_is_unchanged(heads):
    volume = open_volume("torus")
    assert volume.world is None and volume_frame(volume) is None
    camera = fitted_camera(volume)
    assert (camera.azimuth, camera.elevation, camera.mirrored) == (HOME_AZIMUTH, HOME_ELEVATION, False)
    # The view matrix is the plain look-at about z, as before the display frame.
    from pyrr import matrix44
    assert np.array_equal(camera.view_matrix(), matrix44.create_look_at(camera.eye(), camera.target,
                                                                         np.array([0.0, 0.0, 1.0]), dtype="f4"))
    keys = ViewSection().keys(camera)
    expected_eye = {"1": (0, -1, 0), "2": (0, 1, 0), "3": (1, 0, 0), "4": (-1, 0, 0), "5": (0, 0, 1), "6": (0, 0, -1)}
    for key, eye in expected_eye.items():
        keys[key]()
        direction = (camera.eye() - camera.target) / camera.distance
        assert np.allclose(direction, eye, atol=1e-9), key
        right, up = camera.screen_axes()
        assert abs(right @ up) < 1e-9 and abs(right @ direction) < 1e-9 and abs(up @ direction) < 1e-9
    labels = [label for label, _ in view_names(volume)]
    assert labels == ["-y", "+y", "+x", "-x", "+z", "-z"]
    assert [label for label, _ in view_names(open_volume(str(heads["dicom-axial"])))] == ["A", "P", "L", "R", "S", "I"]


def test_a_drag_from_a_view_on_a_pole_does_not_jump():
    camera = OrbitCamera()
    camera.fit((0, 0, 0), (1, 1, 1))
    camera.look_from(*dict((name, angles) for name, _, angles in VIEWS)["superior"])
    camera.orbit(5, 0)
    assert camera.elevation == 90.0
    camera.orbit(0, -10)
    assert camera.elevation == pytest.approx(86.0)
    # Once off the pole, a drag stops a degree short of it, as from any view.
    camera.orbit(0, 100)
    assert camera.elevation == ORBIT_LIMIT


# --- pictures -----------------------------------------------------------------------------------------------

def foreground(volume, gl_ctx, key=None, letters=False) -> np.ndarray:
    """The head's pixels (not the background) seen from the home view, or after `key`."""
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        viewer.state.style.show_box = False
        viewer.show(volume, LEVEL)
        if key is not None:
            ViewSection().keys(viewer.camera)[key]()
        pixels = viewer.render(letters=letters)
        background = np.array(viewer.state.style.background) * 255
    finally:
        viewer.release()
    return np.abs(pixels.astype(float) - background).max(axis=-1) > 30


def reaches(mask) -> dict[str, int]:
    """How far the head reaches from the picture's centre (where the camera looks) to each side, in pixels."""
    rows, columns = np.nonzero(mask)
    centre_row, centre_column = (SIZE[1] - 1) / 2, (SIZE[0] - 1) / 2
    return {"up": centre_row - rows.min(), "down": rows.max() - centre_row,
            "left": centre_column - columns.min(), "right": columns.max() - centre_column}


def iou(a, b) -> float:
    return float((a & b).sum() / (a | b).sum())


@pytest.fixture(scope="module")
def reference(heads, gl_ctx):
    return foreground(open_volume(str(heads["nifti-RAS"])), gl_ctx)


@pytest.mark.parametrize("storage", STORAGES[1:])
def test_the_same_head_stored_another_way_renders_the_same_picture(heads, reference, storage, gl_ctx):
    mask = foreground(open_volume(str(heads[storage])), gl_ctx)
    # The same samples, meshed along other axes: the outlines differ by a pixel here and there (0.9996 seen).
    assert iou(mask, reference) > 0.98
    # Its mirror image (the ear on the other side) overlaps less (0.91), and the ear is on the right.
    assert iou(mask[:, ::-1], reference) < 0.95
    reach = reaches(mask)
    assert reach["right"] > 1.15 * reach["left"] and reach["up"] > 1.2 * reach["down"]


def test_the_head_opens_with_its_top_up_and_its_left_ear_on_the_right(reference):
    # The top bump reaches 44 mm above the centre, the chin 30 below; the left ear 39 mm, the right side 30.
    reach = reaches(reference)
    assert reach["up"] > 1.2 * reach["down"]
    assert reach["right"] > 1.15 * reach["left"]


# Key -> the sides the head reaches further to: (vertical, horizontal); None where it is symmetric.
EXPECTED_REACH = {"1": ("up", "right"), "2": ("up", "left"), "3": ("up", "left"),
                  "4": ("up", "right"), "5": ("up", "left"), "6": ("up", "right")}


@pytest.mark.parametrize("key", sorted(EXPECTED_REACH))
def test_each_view_key_shows_the_head_from_its_side(heads, gl_ctx, key):
    # The mirrored DICOM series: top bump or nose up; ear or nose on the side Slicer's view puts them.
    reach = reaches(foreground(open_volume(str(heads["dicom-axial"])), gl_ctx, key))
    vertical, horizontal = EXPECTED_REACH[key]
    other = {"up": "down", "down": "up", "left": "right", "right": "left"}
    assert reach[vertical] > 1.15 * reach[other[vertical]], reach
    assert reach[horizontal] > 1.15 * reach[other[horizontal]], reach


# --- the command line ----------------------------------------------------------------------------------------

def _command_mask(path) -> np.ndarray:
    from PIL import Image
    pixels = np.asarray(Image.open(path).convert("RGB")).astype(float)
    return np.abs(pixels - pixels[0, 0]).max(axis=-1) > 30   # the corner is background


@pytest.mark.gl
def test_render_draws_the_dicom_head_as_its_nifti_and_adds_letters_on_request(heads, tmp_path):
    from support.command import isoscope_here
    shots = {}
    for name, extra in (("nifti", ()), ("dicom", ()), ("letters", ("--orientation-letters",))):
        source = heads["nifti-RAS" if name == "nifti" else "dicom-sagittal"]
        shots[name] = tmp_path / f"{name}.png"
        result = isoscope_here("render", source, "--iso", LEVEL, "--size", "320x240", "--out", shots[name], *extra)
        assert result.returncode == 0, result.stderr
    nifti, dicom, letters = (_command_mask(shots[name]) for name in ("nifti", "dicom", "letters"))
    assert iou(nifti, dicom) > 0.98
    # The letters: S at the top's middle, I at the bottom's, R at the left's, L at the right's: light pixels
    # where the picture without them has none.
    added = letters & ~dicom
    for rows, columns in (((0, 30), (140, 180)), ((210, 240), (140, 180)), ((100, 140), (0, 30)),
                          ((100, 140), (290, 320))):
        assert added[slice(*rows), slice(*columns)].sum() > 5, (rows, columns)
    assert added.sum() < 400   # four letters, nothing else


# --- the window -----------------------------------------------------------------------------------------------

def test_the_window_opens_a_dicom_head_upright_and_turns_it_with_keys(heads, x_display):
    from support.x_window import run_spawned
    run_spawned(drive_window_views, x_display, str(heads["dicom-coronal"]))


def drive_window_views(x_display, path):
    import os
    os.environ["DISPLAY"] = x_display
    from support.x_window import frames_until, press_key

    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow

    volume = open_volume(path)
    window = ViewerWindow(volume, LEVEL, size=(800, 600), recent=RecentFiles(None))
    try:
        for _ in range(3):
            assert window.draw_frame()
        camera = window.camera
        assert view_letters(volume, camera) == ("A", "S", "L") and camera.mirrored
        # Keys: each view in turn, then r back home.
        for key, expected in EXPECTED_VIEWS.items():
            press_key(window, key)
            assert frames_until(window, lambda expected=expected: view_letters(volume, camera) == expected), key
        press_key(window, "r")
        assert frames_until(window, lambda: view_letters(volume, camera) == ("A", "S", "L"))
    finally:
        window.close()


def test_the_view_buttons_turn_the_camera_when_clicked(heads, gl_ctx):
    from imgui_bundle import imgui
    volume = open_volume(str(heads["dicom-axial"]))
    viewer = HeadlessViewer((700, 1400), ctx=gl_ctx)   # tall: the whole panel shows, the View section too
    try:
        viewer.show(volume, LEVEL)
        viewer.render(panel=True)
        for key in ("5", "3", "1"):
            (left, top), (right, bottom) = viewer._panel.view_section.button_boxes[key]
            assert bottom < 1400
            io = imgui.get_io()
            io.add_mouse_pos_event((left + right) / 2, (top + bottom) / 2)
            viewer.render(panel=True)
            for pressed in (True, False):
                io.add_mouse_button_event(0, pressed)
                viewer.render(panel=True)
            assert view_letters(volume, viewer.camera) == EXPECTED_VIEWS[key], key
    finally:
        viewer.release()


def test_the_2d_slice_view_carries_its_own_letters(heads, gl_ctx):
    from isoscope.viewer.gfx.slices import inset_box
    from isoscope.viewer.ui.orientation import inset_letters
    volume = open_volume(str(heads["dicom-coronal"]))   # (slice: posterior, row: inferior, column: left)
    # A slice across the columns is sagittal; its rows run posterior (right), its columns inferior (up).
    assert inset_letters(volume.world, volume.spacing, 2) == {"right": "P", "left": "A", "top": "I", "bottom": "S"}
    assert inset_letters(volume.world, volume.spacing, 0) == {"right": "I", "left": "S", "top": "L", "bottom": "R"}
    viewer = HeadlessViewer((400, 300), ctx=gl_ctx)
    try:
        viewer.show(volume, LEVEL)
        viewer.state.slices.show(2, True)
        plain, lettered = viewer.render(), viewer.render(letters=True)
    finally:
        viewer.release()
    x, y, width, height = inset_box(volume.data.shape, volume.spacing, 2, (0, 0, 400, 300))
    top = 300 - y - height   # the box's top row in the picture (GL counts from the bottom)
    changed = np.abs(plain.astype(int) - lettered.astype(int)).max(axis=-1) > 60
    inside = changed[top:top + height, x:x + width]
    across, along = (width // 2 - 10, width // 2 + 10), (height // 2 - 10, height // 2 + 10)
    for rows, columns in (((0, 20), across), ((height - 20, height), across), (along, (0, 20)),
                          (along, (width - 20, width))):   # top, bottom, left, right
        assert inside[slice(*rows), slice(*columns)].sum() > 5, (rows, columns)


def test_a_saved_scene_of_a_scan_seen_from_above_redraws_pixel_for_pixel(heads, gl_ctx):
    from isoscope.viewer.model.scene_file import scene_of
    from isoscope.viewer.ui.headless import scene_pixels
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        viewer.show(open_volume(str(heads["dicom-sagittal"])), LEVEL)
        ViewSection().keys(viewer.camera)["5"]()   # on the pole: elevation 90
        viewer.camera.orbit(40, 0)                 # and turned about it
        picture = viewer.picture()
        scene = scene_of(viewer.state, viewer.camera, SIZE)
    finally:
        viewer.release()
    assert scene["camera"]["elevation"] == 90
    assert np.array_equal(scene_pixels(scene), picture)
