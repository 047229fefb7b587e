"""Several surfaces at once (issue 10): levels from one volume, translucency by weighted blended OIT,
colour by a scalar through a colour map, and the CLI's several --iso.  Pixel facts from real renders."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
from PIL import Image
from support.command import assert_one_line_error, isoscope_here
from support.panel import assert_marker_at, click_histogram
from support.x_window import frames_until, run_spawned

from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

SIZE = (160, 120)
CENTRE = (60, 80)        # (row, column) of the image centre
OUTER, INNER = 0.0, -0.35  # levels of the sphere's signed distance: radii 0.7 and 0.35
OUTER_RGB, INNER_RGB = np.array([0.9, 0.2, 0.1]), np.array([0.1, 0.3, 0.9])


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    headless.state.style.show_box = False
    headless.state.style.lighting = False   # flat colours: the blend is all that decides a pixel
    yield headless
    headless.release()


def sphere():
    return open_volume("sphere", resolution=40)


def nested_shells(viewer, azimuth, opacity):
    """An outer translucent shell (level OUTER) around an inner opaque one (level INNER)."""
    viewer.show_levels(sphere(), [OUTER, INNER], [opacity], azimuth=azimuth, elevation=0)
    state = viewer.state
    state.levels.set_color(0, OUTER_RGB)
    state.levels.set_color(1, INNER_RGB)
    return viewer.render().astype(float)


@pytest.mark.parametrize("azimuth", [0, 180])
def test_an_inner_opaque_shell_shows_through_an_outer_translucent_one_as_the_blend_predicts(viewer, azimuth):
    opacity = 0.4
    image = nested_shells(viewer, azimuth, opacity)
    background = np.array(viewer.state.style.background)
    # Over the inner shell one translucent layer (the outer shell's near side) covers an opaque one:
    # weighted blended OIT is exact there, the "over" operator.
    expected = 255 * (opacity * OUTER_RGB + (1 - opacity) * INNER_RGB)
    assert np.abs(image[CENTRE] - expected).max() <= 2
    # Between the radii, the outer shell's near and far sides (same colour) over the background:
    # coverage 1 - (1 - a)^2.
    row, column = CENTRE
    ring = image[row, column + 15]
    reveal = (1 - opacity) ** 2
    assert np.abs(ring - 255 * (OUTER_RGB * (1 - reveal) + background * reveal)).max() <= 2
    # Opaque, the outer shell hides the inner one.
    viewer.state.levels.set_opacity(0, 1.0)
    assert np.abs(viewer.render()[CENTRE].astype(float) - 255 * OUTER_RGB).max() <= 1


def test_a_transparent_background_keeps_the_translucent_blend_in_straight_alpha(viewer):
    viewer.state.style.transparent_background = True
    opacity = 0.4
    image = nested_shells(viewer, 0, opacity)
    assert image.shape[2] == 4 and image[2, 2, 3] == 0
    row, column = CENTRE
    ring = image[row, column + 15]
    assert abs(ring[3] - 255 * (1 - (1 - opacity) ** 2)) <= 2
    assert np.abs(ring[:3] - 255 * OUTER_RGB).max() <= 3


def test_levels_share_one_volume_and_only_the_selected_one_moves(viewer, gl_ctx):
    from support.mesh_checks import assert_same_mesh

    from isoscope.cpu.cubes import marching_cubes_reference

    volume = sphere()
    viewer.show_levels(volume, [OUTER, INNER, 0.3])
    state, scene = viewer.state, viewer.scene
    extractor = scene.extractor
    assert len(state.levels) == 3 and state.levels.selected == 0
    state.levels.select(2)
    state.iso = 0.35   # the slider moves level 3 only
    viewer.render()
    assert scene.extractor is extractor   # one upload, one set of brick ranges
    assert state.levels.values() == pytest.approx([OUTER, INNER, 0.35])
    reference = [marching_cubes_reference(volume.data.astype(np.float32), level, volume.spacing, descent=False)
                 for level in state.levels.values()]
    for mesh, expected in zip(scene.stats.meshes, reference):
        assert_same_mesh(mesh.read(), expected)
    assert [scene.stats.level_stats(i)[0] for i in range(3)] == [len(r[1]) for r in reference]
    state.levels.set_visible(1, False)
    assert len(scene.stats.meshes) == 2
    state.levels.remove(0)
    assert state.levels.values() == pytest.approx([INNER, 0.35]) and state.levels.selected == 1
    viewer.render()
    copies = scene.level_meshes.copies
    assert len(scene.stats.meshes) == 1 and all(level in state.levels.items for level in copies)   # its copy went


def test_more_than_four_levels_or_bad_values_keep_what_was_shown(viewer):
    viewer.show_levels(sphere(), [0.0, 0.1, 0.2, 0.3])
    state = viewer.state
    before = viewer.render()
    low, high = state.value_range
    levels = state.levels
    for refused, words in ((lambda: levels.add(0.4), "at most 4"), (lambda: levels.add(high + 1), "at most 4"),
                           (lambda: levels.set_opacity(0, 1.5), "0..1"), (lambda: levels.select(7), "no surface 8"),
                           (lambda: state.set_color_by("sphere", None), "same shape")):   # the built-in is 64^3
        with pytest.raises(ValueError, match=words) as caught:
            refused()
        assert "\n" not in str(caught.value)
    assert len(state.levels) == 4 and state.color_by is None
    assert np.array_equal(viewer.render(), before)


def test_colour_by_value_gives_each_level_the_map_colour_of_its_value(viewer):
    viewer.show_levels(sphere(), [OUTER, INNER], [0.0], color_by="value", colormap="magma",
                       azimuth=0, elevation=0)
    state = viewer.state
    image = viewer.render().astype(float)
    # The outer level hidden (opacity 0): the centre shows the inner level in the map's colour.
    assert np.abs(image[CENTRE] - 255 * state.color_by.color_at(INNER)).max() <= 1
    assert state.color_by.value_range == pytest.approx(state.value_range)
    state.levels.set_opacity(0, 1.0)
    assert np.abs(viewer.render()[CENTRE].astype(float) - 255 * state.color_by.color_at(OUTER)).max() <= 1


def test_colour_by_a_second_volume_follows_it_across_the_surface(viewer, tmp_path):
    # The second volume is 0 on the low half of axis 0 and 1 on the high half.
    path = tmp_path / "halves.npy"
    np.save(path, np.broadcast_to((np.arange(40) >= 20)[:, None, None], (40, 40, 40)).astype(np.float32))
    viewer.show_levels(sphere(), [OUTER], color_by=str(path), colormap="viridis", azimuth=90, elevation=0)
    color_by = viewer.state.color_by
    image = viewer.render().astype(float)
    row, column = CENTRE
    high, low = image[row, column - 15], image[row, column + 15]   # seen from azimuth 90, axis 0 runs right to left
    assert np.abs(high - 255 * color_by.color_at(1.0)).max() <= 1
    assert np.abs(low - 255 * color_by.color_at(0.0)).max() <= 1


@pytest.mark.gl
def test_render_draws_a_colour_bar_and_export_writes_one_file_per_level(tmp_path):
    import trimesh
    out = tmp_path / "shells.png"
    result = isoscope_here("render", "sphere", "--resolution", "32", "--iso", "0", "--iso", "-0.3", "--opacity",
                           "0.3,1", "--color-by", "gradient", "--color-by-map", "viridis", "--size", "320x240",
                           "--out", out)
    assert result.returncode == 0, result.stderr
    image = np.asarray(Image.open(out).convert("RGB")).astype(int)
    from isoscope.viewer.model.colorby import colormap_rgb
    lut = np.round(colormap_rgb("viridis") * 255)
    from isoscope.viewer.gfx.colorbar import BAR_WIDTH, LINE, MARGIN, MAX_BAR_SHARE
    bar = image[:, 320 - MARGIN - BAR_WIDTH // 2]   # the map from top (high) to bottom (low), at the right
    top = MARGIN + 2 * LINE
    bottom = top + int(MAX_BAR_SHARE * 240)
    assert np.abs(bar[top + 1] - lut[-1]).max() <= 3 and np.abs(bar[bottom - 2] - lut[0]).max() <= 3
    assert np.abs(bar[(top + bottom) // 2] - lut[len(lut) // 2]).max() <= 8

    mesh_out = tmp_path / "head.ply"
    result = isoscope_here("export", "sphere", "--resolution", "32", "--iso", "0", "--iso", "-0.3", "--out", mesh_out)
    assert result.returncode == 0, result.stderr
    written = sorted(p.name for p in tmp_path.glob("head*.ply"))
    assert written == ["head_iso-0.3.ply", "head_iso0.ply"]
    meshes = {name: trimesh.load(tmp_path / name) for name in written}
    assert meshes["head_iso-0.3.ply"].area < meshes["head_iso0.ply"].area   # the inner level is the smaller


@pytest.mark.parametrize("args, words", [
    (("--iso", "0", "--iso", "0.1", "--iso", "0.2", "--iso", "0.3", "--iso", "0.4"), ("at most 4",)),
    (("--iso", "0", "--opacity", "0.5,0.5"), ("opacities",)),
    (("--opacity", "1.5"), ("0..1",)),
    (("--color-by-map", "no-such-map"), ("colour map",)),
    (("--color-by", "gyroid"), ("same shape",)),
])
@pytest.mark.gl
def test_bad_levels_and_looks_are_one_line_errors(tmp_path, args, words):
    result = isoscope_here("render", "sphere", "--resolution", "32", *args, "--out", tmp_path / "x.png")
    assert_one_line_error(result, *words)
    assert not (tmp_path / "x.png").exists()


def test_a_drag_previews_the_moving_level_within_what_the_other_levels_leave_of_the_budget(gl_ctx, monkeypatch):
    import isoscope.viewer.gfx.surface as surface_module
    from isoscope.viewer.gfx.scene import GpuScene
    from isoscope.viewer.model.state import ViewerState

    state = ViewerState()
    scene = GpuScene(gl_ctx, state, previews=True)
    try:
        scene.show(open_volume("gyroid", resolution=48), 0.0)
        alone = scene.stats.n_triangles
        monkeypatch.setattr(surface_module, "PREVIEW_TRIANGLES", int(alone * 1.5))  # one level: no preview

        def drag():
            for value in (0.02, 0.04, 0.06):
                state.iso = value
                scene.update(0.04)
            return scene.stats.preview_step
        assert drag() == 1
        state.levels.add(0.3)
        scene.update(0.0)
        state.levels.select(0)   # the other level takes most of the budget
        scene.update(0.0)
        other = scene.stats.level_stats(1)[0]
        assert other > alone // 2
        assert drag() > 1
        assert scene.stats.meshes[1].n_triangles == other   # the level not dragged stays in full
    finally:
        scene.release()


def test_the_histogram_marks_every_level_and_a_click_sets_only_the_selected_one(gl_ctx):
    viewer = HeadlessViewer((900, 760), ctx=gl_ctx)
    try:
        viewer.show_levels(open_volume("bucky"), [64.0, 190.0])
        state = viewer.state
        image = viewer.render(panel=True)
        for i, level in enumerate((64.0, 190.0)):
            assert_marker_at(image, viewer._panel.histogram_box, state.levels.color(i, state.style.front_color),
                             level, state.value_range)
        state.levels.select(1)
        click_histogram(viewer, 0.25)
        low, high = state.value_range
        assert state.levels.values() == pytest.approx([64.0, low + 0.25 * (high - low)], abs=0.01 * (high - low))
    finally:
        viewer.release()


@pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")
def test_the_real_window_blends_a_translucent_shell_over_an_opaque_one(x_display, tmp_path):
    # The window draws to its default framebuffer without multisampling: the single-sample resolve.
    run_spawned(drive_window_with_two_surfaces, x_display, tmp_path)


def drive_window_with_two_surfaces(x_display, tmp_path):
    import os
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow

    window = ViewerWindow(sphere(), iso=OUTER, size=(640, 400), screenshot_dir=tmp_path, recent=RecentFiles(None))
    try:
        state, opacity = window.state, 0.4
        state.style.lighting = state.style.show_box = False
        state.levels.add(INNER)
        state.levels.set_color(1, INNER_RGB)
        state.levels.set_color(0, OUTER_RGB)
        state.levels.set_opacity(0, opacity)

        def matching(rgb):
            window.request_screenshot()
            assert frames_until(window, lambda: window.last_screenshot is not None)
            shot = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(float)
            window.last_screenshot = None
            return int((np.abs(shot - 255 * rgb).max(axis=2) <= 2).sum())

        blend = opacity * OUTER_RGB + (1 - opacity) * INNER_RGB
        assert matching(blend) > 200          # the inner shell's disc, seen through the outer one
        state.levels.set_opacity(0, 1.0)
        assert matching(blend) == 0 and matching(OUTER_RGB) > 200
    finally:
        window.close()
