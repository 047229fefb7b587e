"""Slices, their isocurves, window/level and the clip plane, as pixels of real headless renders.

Where a pixel should be is worked out from the camera's own matrices (world point -> pixel),
and what colour from the data through the `cmap` library's colour map, so the facts do not
depend on the renderer's code.
"""
from __future__ import annotations

import ctypes.util
import os
import shutil

import numpy as np
import pytest
from cmap import Colormap
from PIL import Image
from support.command import isoscope_here

from isoscope import marching_cubes
from isoscope.viewer.gfx.slices import inset_box
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.volume import finish_volume

SIZE = (320, 240)
RED = (1.0, 0.0, 0.0)


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    headless.state.style.show_box = False
    yield headless
    headless.release()


def volume_of(data, spacing=(1.0, 1.0, 1.0), direction="descent"):
    return finish_volume(np.ascontiguousarray(data, np.float32), spacing=spacing, name="test", source="test",
                         gradient_direction=direction, default_level=None)


def sphere(n=40, radius=0.6):
    axis = np.linspace(-1, 1, n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return volume_of(np.sqrt(x * x + y * y + z * z) - radius, direction="ascent")


def to_pixels(viewer, points) -> np.ndarray:
    """World points (N, 3) -> (N, 2) pixel (column, row) positions, row 0 at the top, as the image has them."""
    camera, (width, height) = viewer.camera, SIZE
    clip = np.c_[points, np.ones(len(points))] @ camera.view_matrix() @ camera.projection_matrix(width / height)
    ndc = clip[:, :3] / clip[:, 3:]
    return np.c_[(ndc[:, 0] + 1) / 2 * width, (1 - ndc[:, 1]) / 2 * height]


def expected_colors(values, window, centre, name) -> np.ndarray:
    return Colormap(name)(np.clip((values - (centre - window / 2)) / window, 0, 1))[:, :3] * 255


def surface_mask(image, background) -> np.ndarray:
    return np.abs(image.astype(int) - np.round(np.array(background) * 255)).max(axis=2) > 3


@pytest.mark.parametrize("colormap", ["gray", "viridis"])
def test_a_slice_shows_the_data_through_the_colour_map(viewer, colormap):
    n = 32
    i, j, k = np.indices((n, n, n), dtype=float)
    pattern = 0.5 + 0.5 * np.sin(j / 5.0) * np.cos(k / 6.0)
    # The surface (level 15.5) lies near x index 3, behind the slice at x = 20 seen from +x.
    volume = volume_of(pattern + 5.0 * i, spacing=(1.0, 1.5, 0.8))
    viewer.show(volume, iso=15.5, azimuth=0, elevation=0)
    window, centre = 1.2, 100.5
    slices = viewer.state.slices
    slices.show(0, True, 20)
    slices.set_window(window, centre)
    slices.set_colormap(colormap)
    viewer.state.slices.inset = False
    image = viewer.render().astype(float)

    rows, columns = np.meshgrid(np.arange(3, n - 3), np.arange(3, n - 3), indexing="ij")
    points = np.c_[np.full(rows.size, 20.0), rows.ravel() * 1.5, columns.ravel() * 0.8]
    pixels = np.floor(to_pixels(viewer, points)).astype(int)
    shown = image[pixels[:, 1], pixels[:, 0]]
    expected = expected_colors(volume.data[20][rows, columns].ravel(), window, centre, colormap)
    difference = np.abs(shown - expected).max(axis=1)
    assert np.percentile(difference, 95) <= 6 and difference.max() <= 12, difference.max()
    assert np.ptp(expected[:, :3]) > 100   # the pattern spans the map, so a flat slice would fail


def test_the_isocurve_on_a_slice_is_where_the_mesh_crosses_it(viewer):
    volume = sphere()
    viewer.show(volume, iso=0.0, azimuth=0, elevation=0)
    state, index = viewer.state, 24
    state.style.front_color = RED   # the curve's colour; the grey map has no red pixel
    state.slices.show(0, True, index)
    state.slices.set_clip(0, index, hide_above=True)   # the surface in front of the slice goes
    state.slices.inset = False
    image = viewer.render().astype(int)
    curve = (image[:, :, 0] - image[:, :, 1:].max(axis=2)) > 60
    curve_pixels = np.argwhere(curve)[:, ::-1] + 0.5                  # (column, row) centres

    verts, faces, _, _ = marching_cubes(volume.data, 0.0, spacing=volume.spacing, gradient_direction="ascent")
    on_plane = np.abs(verts[:, 0] - index * volume.spacing[0]) < 1e-5
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = edges[on_plane[edges].all(axis=1)]                         # the mesh's edges lying in the plane
    assert len(edges) > 20
    t = np.linspace(0, 1, 9)[:, None, None]
    cut = (verts[edges[:, 0]] * (1 - t) + verts[edges[:, 1]] * t).reshape(-1, 3)
    cut_pixels = to_pixels(viewer, cut)

    def farthest(from_points, to_points):
        distance = np.linalg.norm(from_points[:, None, :] - to_points[None, :, :], axis=2)
        return distance.min(axis=1).max()

    assert len(curve_pixels) > 100
    assert farthest(curve_pixels, cut_pixels) < 2.0     # every curve pixel sits on the mesh's cut
    assert farthest(cut_pixels, curve_pixels) < 1.5     # and the whole cut is drawn


def test_the_clipped_half_has_no_surface_and_the_cut_is_capped_with_the_slice(viewer):
    volume = sphere()
    viewer.show(volume, iso=0.0, azimuth=0, elevation=0)
    state, background = viewer.state, viewer.state.style.background
    half = SIZE[1] // 2
    whole = surface_mask(viewer.render(), background)
    assert whole[:half - 2].sum() > 1000 and whole[half + 2:].sum() > 1000

    middle = (volume.data.shape[2] - 1) / 2   # the camera's height: the cut is seen edge-on
    state.slices.set_clip(2, middle, hide_above=True)
    clipped = surface_mask(viewer.render(), background)
    assert not clipped[:half - 2].any()
    assert (clipped[half + 2:] == whole[half + 2:]).mean() > 0.99

    state.slices.set_clip(2, middle, hide_above=False)
    flipped = surface_mask(viewer.render(), background)
    assert not flipped[half + 2:].any() and flipped[:half - 2].sum() > 1000
    state.slices.set_clip(None)
    assert (surface_mask(viewer.render(), background) == whole).all()

    # From above, the cut shows the slice's values where the surface would be.
    viewer.camera.elevation = 60
    state.slices.set_clip(2, 19.0, hide_above=True)
    image = viewer.render().astype(float)
    centre = np.array([[19.5, 19.5, 19.0]]) * volume.spacing
    column, row = np.floor(to_pixels(viewer, centre)[0]).astype(int)
    value = volume.data[19:21, 19:21, 19].mean()
    settings = state.slices
    expected = expected_colors(np.array([value]), settings.window, settings.centre, "gray")[0]
    assert np.abs(image[row, column] - expected).max() <= 6


def test_the_2d_view_shows_the_active_slice(viewer):
    volume = sphere()
    viewer.show(volume, iso=0.0)
    state = viewer.state
    state.style.front_color = RED
    state.slices.show(1, True, 19)
    state.slices.show(2, True, 10)
    image = viewer.render().astype(int)
    x, y, width, height = inset_box(volume.data.shape, volume.spacing, 2, (0, 0, *SIZE))
    top = SIZE[1] - y - height
    inset = image[top:top + height, x:x + width]
    # Rows of the image are the slice's columns (y up); the circle of the cut at z = 10 is red.
    curve = (inset[:, :, 0] - inset[:, :, 1:].max(axis=2)) > 60
    rows, columns = np.nonzero(curve)
    radius_px = np.hypot(rows - height / 2, columns - width / 2)
    expected_radius = np.sqrt(0.6 ** 2 - (1 - 20 / 39) ** 2) / 2 * width
    assert len(rows) > 50 and np.abs(radius_px - expected_radius).max() < 2.5
    state.slices.inset = False
    assert not np.array_equal(viewer.render()[top:top + height, x:x + width], image[top:top + height, x:x + width])


def test_bad_values_are_refused_and_the_state_keeps_what_it_showed(viewer):
    viewer.show(sphere(), iso=0.0)
    state, slices = viewer.state, viewer.state.slices
    slices.show(2, True, 5)
    before = (list(state.slices.shown), list(state.slices.index), state.slices.colormap, state.slices.window)
    for refused, words in ((lambda: slices.show(2, True, 40), "z=40"),
                           (lambda: slices.show(0, True, -1), "x=-1"),
                           (lambda: slices.set_colormap("no-such-map"), "no-such-map"),
                           (lambda: slices.set_window(-1.0, None), "window"),
                           (lambda: slices.set_clip(1, 99.0), "y=99")):
        with pytest.raises(ValueError, match=words) as caught:
            refused()
        assert "\n" not in str(caught.value)
        assert (list(state.slices.shown), list(state.slices.index), state.slices.colormap,
                state.slices.window) == before
        assert state.slices.clip is None


@pytest.mark.gl
def test_render_command_draws_slices_and_refuses_bad_values_in_one_line(tmp_path):
    out = tmp_path / "slice.png"
    result = isoscope_here("render", "torus", "--slice", "z=32", "--clip", "x=40:-", "--colormap", "viridis",
                           "--window", "1", "--level", "0.3", "--size", "320x240", "--out", out)
    assert result.returncode == 0, result.stderr
    image = np.asarray(Image.open(out).convert("RGB")).astype(int)
    x, y, width, height = inset_box((64, 64, 64), (1, 1, 1), 2, (0, 0, 320, 240))
    inset = image[240 - y - height:240 - y, x:x + width]
    assert np.ptp(inset[:, :, 1]) > 100   # viridis from dark to bright in the 2-D view
    for args, words in ((("--slice", "z=64"), ["z=64", "0 to 63"]), (("--slice", "w=3"), ["--slice", "x, y or z"]),
                        (("--colormap", "nope"), ["nope"]), (("--clip", "z=10:up"), ["--clip"]),
                        (("--window", "0"), ["window"])):
        result = isoscope_here("render", "torus", *args, "--out", tmp_path / "bad.png")
        assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1 and all(w in result.stderr for w in words), result.stderr
    assert not (tmp_path / "bad.png").exists()


needs_x = pytest.mark.skipif(shutil.which("Xvfb") is None or ctypes.util.find_library("Xtst") is None,
                             reason="Xvfb and libXtst are needed for the window test")


@needs_x
def test_a_click_on_the_panel_shows_a_slice_in_the_window(x_display, tmp_path):
    from support.x_window import run_spawned
    run_spawned(click_slice_checkbox, x_display, tmp_path)


def click_slice_checkbox(x_display, tmp_path):
    os.environ["DISPLAY"] = x_display
    from support.x_window import Pointer, frames_until

    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(720, 760), recent=RecentFiles(None),
                          screenshot_dir=tmp_path)
    try:
        for _ in range(3):
            assert window.draw_frame()
        state, pointer = window.state, Pointer(window)
        assert not state.slices.shown[2]
        (left, top), (right, bottom) = window.panel.slices.checkbox_boxes[2]
        point = ((left + right) / 2, (top + bottom) / 2)
        pointer.hover(window, point)
        pointer.send(("press", 1))
        window.draw_frame()
        pointer.send(("release", 1))
        assert frames_until(window, lambda: state.slices.shown[2]), "the click did not show the z slice"
        assert state.slices.inset_axis() == 2
        window.request_screenshot()
        assert frames_until(window, lambda: window.last_screenshot is not None)
        shot = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(int)
        height, width = shot.shape[:2]
        x, y, w, h = inset_box((32, 32, 32), state.volume.spacing, 2, (0, 0, width, height))
        inset = shot[height - y - h:height - y, x:x + w]
        # The 2-D view: the slice's grey values around the circle where the sphere crosses it.
        grey = np.abs(inset - inset.mean(axis=2, keepdims=True)).max(axis=2) < 3
        assert grey.mean() > 0.8 and np.ptp(inset[grey][:, 0]) > 100
    finally:
        window.close()
