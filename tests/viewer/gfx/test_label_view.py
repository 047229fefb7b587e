"""A label map in the viewer and in renders (issue 26, point 7): the clip's cut in each label's colour (on
4.3 and on 4.1), a label hidden or faded without extracting again, a half-opaque label showing the other
through it, names and colours from the file beside the segmentation, and a saved scene keeping the looks."""
from __future__ import annotations

import ctypes
import ctypes.util
import json
import os
import time

import numpy as np
import pytest
from PIL import Image
from support.command import isoscope, isoscope_here
from support.x_window import run_spawned

from isoscope.viewer.model.scene_file import apply_scene, scene_of
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

SIZE = (320, 240)
RED, GREEN = (200, 30, 30), (30, 200, 60)     # labels 1 and 7, from seg.ctbl beside seg.npy
LABEL_1_CUT, LABEL_7_CUT = (9.0, 12.0, 12.0), (19.0, 12.0, 12.0)   # on the cut z = 12, inside each label
CAP_VIEW = {"azimuth": -60.0, "elevation": 60.0}   # from above: the cut of "hide above z = 12" faces the camera


@pytest.fixture
def segmentation(tmp_path):
    """Two labels side by side along x, touching at x = 13.5; no world frame, so world = index."""
    labels = np.zeros((30, 28, 26), np.uint8)
    labels[4:14, 5:20, 4:20] = 1
    labels[14:25, 5:20, 4:20] = 7
    np.save(tmp_path / "seg.npy", labels)
    (tmp_path / "seg.ctbl").write_text(f"0 background 0 0 0 0\n1 left {' '.join(map(str, RED))} 255\n"
                                       f"7 right {' '.join(map(str, GREEN))} 255\n")
    return tmp_path / "seg.npy"


@pytest.fixture
def viewer(gl_ctx, segmentation):
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    viewer.show(open_volume(str(segmentation)), **CAP_VIEW)
    assert viewer.state.show_labels()
    yield viewer
    viewer.release()


def pixel_of(camera, point, size=SIZE) -> tuple[int, int]:
    """(row, column) of the world `point` in a picture of `size` (top row first)."""
    width, height = size
    clip = np.array([*point, 1.0]) @ camera.view_matrix() @ camera.projection_matrix(width / height)
    x, y = clip[:2] / clip[3]
    return int((1 - y) / 2 * height), int((x + 1) / 2 * width)


def patch(pixels, camera, point) -> np.ndarray:
    """The 3 x 3 pixels round `point`, as (9, 3) ints."""
    row, column = pixel_of(camera, point)
    return pixels[row - 1:row + 2, column - 1:column + 2, :3].reshape(-1, 3).astype(int)


def green_pixels(pixels) -> int:
    r, g, b = (pixels[..., k].astype(int) for k in range(3))
    return int(np.count_nonzero((g > r + 60) & (g > b + 60)))


def test_the_clip_cap_has_each_labels_colour(viewer):
    viewer.state.slices.set_clip(2, 12.0)
    pixels = viewer.render()
    for point, color in ((LABEL_1_CUT, RED), (LABEL_7_CUT, GREEN), ((13.0, 12.0, 12.0), RED),
                         ((14.0, 12.0, 12.0), GREEN)):   # half a voxel either side of where they touch
        assert np.abs(patch(pixels, viewer.camera, point) - color).max() <= 2, point
    assert viewer.state.labels.layer(1).title == "left"   # named by seg.ctbl beside seg.npy


def test_toggling_a_label_keeps_the_meshes_and_drops_its_colour(viewer):
    viewer.state.slices.set_clip(2, 12.0)
    before = viewer.render()
    meshes = dict(viewer.scene.labels.meshes)
    assert viewer.scene.labels.extractions == 1 and green_pixels(before) > 500
    viewer.state.labels.set_visible(7, False)
    hidden = viewer.render()
    assert green_pixels(hidden) == 0   # neither its surface nor its cut
    assert np.abs(patch(hidden, viewer.camera, LABEL_1_CUT) - RED).max() <= 2
    viewer.state.labels.set_visible(7, True)
    assert np.array_equal(viewer.render(), before)
    viewer.state.labels.set_opacity(7, 0.0)
    assert green_pixels(viewer.render()) == 0
    # Not one extraction since the label map was shown: the same meshes, only the draw list changed.
    assert viewer.scene.labels.extractions == 1
    assert viewer.scene.labels.meshes == meshes


def test_a_half_opaque_label_shows_the_other_through_it(viewer):
    camera = viewer.camera
    # Look along x from the low side (label 1 in front of label 7), a little from above.
    azimuth = min((0.0, 90.0, 180.0, 270.0), key=lambda a: (camera.look_from(a, 10.0), camera.eye()[0])[1])
    camera.look_from(azimuth, 10.0)
    opaque = viewer.render()
    behind = pixel_of(camera, (19.5, 12.0, 12.0))
    assert opaque[behind][0] > opaque[behind][1] + 40   # label 1's red covers label 7
    viewer.state.labels.set_opacity(1, 0.5)
    half = viewer.render()
    assert int(half[behind][1]) - int(opaque[behind][1]) > 40   # label 7's green through it
    assert half[behind][0] > 40   # and label 1 still tints it
    assert viewer.scene.labels.extractions == 1


def test_a_saved_scene_keeps_the_labels_looks(gl_ctx, viewer, segmentation):
    viewer.state.labels.set_visible(7, False)
    viewer.state.labels.set_opacity(1, 0.25)
    scene = json.loads(json.dumps(scene_of(viewer.state, viewer.camera, SIZE)))
    again = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        again.show(open_volume(str(segmentation)))
        apply_scene(scene, again.state, again.camera)
        assert [(layer.label, layer.visible, layer.opacity, layer.name, layer.color)
                for layer in again.state.labels.layers] == \
               [(1, True, 0.25, "left", tuple(c / 255 for c in RED)), (7, False, 1.0, "right",
                                                                       tuple(c / 255 for c in GREEN))]
    finally:
        again.release()


@pytest.mark.parametrize("gl41", [True, False], ids=["gl41", "gl43"])
def test_render_caps_the_labels_in_their_colours(viewer, segmentation, tmp_path, gl41):
    """`isoscope render --labels --clip` (on macOS's 4.1 too: the cut's shader is GLSL 410)."""
    out = tmp_path / "cut.png"
    args = ("render", segmentation, "--labels", "--clip", "z=12", "--azimuth", CAP_VIEW["azimuth"],
            "--elevation", CAP_VIEW["elevation"], "--size", f"{SIZE[0]}x{SIZE[1]}", "--out", out)
    if gl41:   # Mesa offers a 4.1 core context and no more, as a Mac does (as tests/viewer/gfx/test_gl41.py): a process
        result = isoscope(*args, env_drop=[k for k in os.environ if k.startswith("MESA_GL")],
                          env_add={"MESA_GL_VERSION_OVERRIDE": "4.1", "MESA_GLSL_VERSION_OVERRIDE": "410"})
    else:      # on 4.3 the command runs in this process, on the tests' context
        result = isoscope_here(*args)
    assert result.returncode == 0, result.stderr
    pixels = np.asarray(Image.open(out).convert("RGB"))
    for point, color in ((LABEL_1_CUT, RED), (LABEL_7_CUT, GREEN)):
        assert np.abs(patch(pixels, viewer.camera, point) - color).max() <= 2, point


@pytest.mark.skipif(ctypes.util.find_library("Xtst") is None, reason="libXtst is not installed")
def test_the_panel_fades_and_hides_a_label_without_extracting(x_display, segmentation):
    """The Labels rows driven by the pointer through X (XTest) in the real window."""
    run_spawned(panel_rows, x_display, str(segmentation))


def panel_rows(x_display, segmentation):
    os.environ["DISPLAY"] = x_display
    import glfw

    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    xtst, xlib = (ctypes.CDLL(ctypes.util.find_library(name)) for name in ("Xtst", "X11"))
    xtst.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_ulong]
    xtst.XTestFakeButtonEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
    xlib.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]

    window = ViewerWindow(open_volume(segmentation), size=(800, 600), recent=RecentFiles(None))

    def click(box, fraction=0.5):
        """A left click `fraction` of the way across `box` (window units), as a hand: arrive, press, release."""
        (left, top), (right, bottom) = box
        x0, y0 = glfw.get_window_pos(window.window)
        display = glfw.get_x11_display()
        for press in (None, True, False):
            if press is None:
                xtst.XTestFakeMotionEvent(display, -1, round(x0 + left + fraction * (right - left)),
                                          round(y0 + (top + bottom) / 2), 0)
            else:
                xtst.XTestFakeButtonEvent(display, 1, press, 0)
            xlib.XSync(display, 0)
            time.sleep(0.05)
            for _ in range(2):
                window.draw_frame()

    try:
        window.state.show_labels()
        for _ in range(3):
            assert window.draw_frame()
        labels, boxes = window.state.labels, window.panel.labels_section.boxes
        assert sorted(boxes) == [1, 7] and window.scene.labels.extractions == 1
        click(boxes[7]["opacity"], 0.3)
        assert 0.1 < labels.layer(7).opacity < 0.5, labels.layer(7).opacity
        assert [look.opacity for look in window.scene.stats.looks] == [1.0, labels.layer(7).opacity]
        click(boxes[1]["visible"])
        assert not labels.layer(1).visible and labels.layer(7).visible
        assert [look.color for look in window.scene.stats.looks] == [labels.layer(7).color]
        assert window.scene.labels.extractions == 1
    finally:
        window.close()


def test_the_clip_cap_of_a_view_placed_off_the_grid_lies_on_the_cut(gl_ctx, segmentation):
    """A coarse view of a pyramid level off the full level's grid (Volume.origin, big_volume.from_level) draws
    its label surfaces at its origin and the clip cuts them there: the coloured cut is drawn there too, each
    label's colour on its own part of the cut (label_scene.cap_corners)."""
    import dataclasses
    origin = (3.0, -2.5, 4.0)
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        viewer.show(dataclasses.replace(open_volume(str(segmentation)), origin=origin), **CAP_VIEW)
        assert viewer.state.show_labels()
        viewer.state.slices.set_clip(2, 12.0)
        pixels = viewer.render()
        for point, color in ((LABEL_1_CUT, RED), (LABEL_7_CUT, GREEN), ((13.0, 12.0, 12.0), RED),
                             ((14.0, 12.0, 12.0), GREEN)):
            placed = tuple(p + o for p, o in zip(point, origin))
            assert np.abs(patch(pixels, viewer.camera, placed) - color).max() <= 2, point
    finally:
        viewer.release()
