"""The viewer's time axis (issue 27): a series steps and plays in the headless viewer through its model
(model/series.py), keeping levels, slices and clip; the fixed range keeps the slider's ends; a bad time
point is one line and the last good one stays; in the real window `]` steps and Record writes a movie
that an independent reader (imageio/ffmpeg) reads back."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
from support.x_window import frames_until, press_key, run_spawned

from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

SIZE = (160, 120)
N = 32
TIMES = 4


def ball(t: int, n: int = N) -> np.ndarray:
    """Distance to a point that moves along x with t, scaled by t + 1 (each time point its own range)."""
    axis = np.linspace(-1.0, 1.0, n)
    x, y, z = axis[:, None, None], axis[None, :, None], axis[None, None, :]
    return (np.sqrt((x + 0.3 - 0.2 * t) ** 2 + y * y + z * z) * (t + 1)).astype(np.float32)


@pytest.fixture
def series(tmp_path):
    """A glob of TIMES .npy files, one per time point: its pattern."""
    for t in range(TIMES):
        np.save(tmp_path / f"ball_{t}.npy", ball(t))
    return str(tmp_path / "ball_*.npy")


@pytest.fixture(params=["glob", "npy", "nifti"])
def any_series(request, tmp_path):
    """The same series as a glob of .npy files, a 4-D .npy (time first) and a 4-D NIfTI (time last)."""
    if request.param == "glob":
        for t in range(TIMES):
            np.save(tmp_path / f"ball_{t}.npy", ball(t))
        return str(tmp_path / "ball_*.npy")
    stack = np.stack([ball(t) for t in range(TIMES)])
    if request.param == "npy":
        np.save(tmp_path / "balls.npy", stack)
        return str(tmp_path / "balls.npy")
    import nibabel
    nibabel.save(nibabel.Nifti1Image(np.moveaxis(stack, 0, -1), np.eye(4)), tmp_path / "balls.nii")
    return str(tmp_path / "balls.nii")


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    yield headless
    headless.release()


def test_a_series_steps_with_the_model_and_its_picture_and_mesh_follow_while_the_view_stays(viewer, any_series,
                                                                                          tmp_path):
    viewer.open(any_series)
    state = viewer.state
    assert state.series.active and state.series.count == TIMES and state.series.shown == 0
    state.levels.set_value(0.5)
    state.levels.add(0.2)                    # a second surface
    state.slices.show(2, index=10)           # a slice and a clip, set by hand
    state.slices.set_clip(0, 12.0)
    state.set_smooth(2)                      # a mesh mode
    first = viewer.render()
    camera = (viewer.camera.azimuth, viewer.camera.elevation, viewer.camera.distance)

    state.series.step(+1)
    second = viewer.render()                 # a render waits for the worker's read
    assert state.series.shown == state.series.index == 1
    assert np.abs(first.astype(int) - second).sum() > 0
    assert state.levels.values() == [0.5, 0.2] and state.levels.selected == 1
    assert state.slices.shown[2] and state.slices.index[2] == 10 and state.slices.clip.position == 12.0
    assert (viewer.camera.azimuth, viewer.camera.elevation, viewer.camera.distance) == camera
    assert np.array_equal(state.volume.data, ball(1))
    assert state.mesh_options.smooth == 2
    state.set_smooth(0)                      # the mesh compared below is the plain one

    # The mesh of time point 1 is that of the 3-D volume alone at the same level.
    state.levels.select(0)
    viewer.update()
    verts, faces = viewer.scene.surface.shown.read_mesh()[:2]
    np.save(tmp_path / "alone.npy", ball(1))
    alone = HeadlessViewer(SIZE, ctx=viewer.ctx)
    try:
        alone.show(open_volume(str(tmp_path / "alone.npy")), 0.5)
        alone_verts, alone_faces = alone.scene.surface.shown.read_mesh()[:2]
    finally:
        alone.release()
    assert len(faces) > 0
    assert np.array_equal(faces, alone_faces) and np.allclose(verts, alone_verts)

    state.series.step(-2)                    # wraps round to the last
    viewer.render()
    assert state.series.shown == TIMES - 1


def test_the_range_is_the_time_points_own_unless_fixed_to_the_whole_series(viewer, series):
    viewer.open(series)
    state = viewer.state
    assert state.value_range == pytest.approx(open_volume(series, time=0).value_range)
    state.series.step(+1)
    viewer.render()
    own = open_volume(series, time=1).value_range
    assert state.value_range == pytest.approx(own)     # per time point: it moves

    state.series.set_fixed_range(True)
    viewer.render()                                     # waits for the whole series' range
    ranges = [open_volume(series, time=t).value_range for t in range(TIMES)]
    whole = (min(r[0] for r in ranges), max(r[1] for r in ranges))
    assert state.value_range == pytest.approx(whole)
    histogram = state.histogram.copy()
    for _ in range(TIMES):
        state.series.step(+1)
        viewer.render()
        assert state.value_range == pytest.approx(whole)   # the slider does not jump
        assert np.array_equal(state.histogram, histogram)

    state.series.set_fixed_range(False)
    viewer.render()
    assert state.value_range == pytest.approx(open_volume(series, time=state.series.shown).value_range)


def test_playback_loops_and_bounces_at_its_frame_rate(viewer, series):
    viewer.open(series)
    state, scene = viewer.state, viewer.scene
    state.series.set_fps(10)
    state.series.toggle_play()
    seen = []
    for _ in range(6):
        scene.update(0.1, wait=True)   # one period a frame: the next time point each frame (read on the worker)
        seen.append(state.series.shown)
    assert seen == [1, 2, 3, 0, 1, 2]
    state.series.set_mode("bounce")
    seen = []
    for _ in range(6):
        scene.update(0.1, wait=True)
        seen.append(state.series.shown)
    assert seen == [3, 2, 1, 0, 1, 2]
    state.series.toggle_play()
    scene.update(0.1, wait=True)
    assert state.series.shown == 2 and not state.series.playing
    with pytest.raises(ViewerError, match="frames a second"):
        state.series.set_fps(0)


def test_a_time_point_of_another_shape_is_one_line_and_the_last_good_one_stays(viewer, series, tmp_path):
    np.save(tmp_path / "ball_2.npy", ball(2, N + 4))
    viewer.open(series)
    state = viewer.state
    state.series.step(+1)
    viewer.render()
    before = state.volume
    state.series.step(+1)
    with pytest.raises(ViewerError) as error:
        viewer.update()
    message = str(error.value)
    assert "time point 2" in message and "one shape" in message and "\n" not in message
    assert state.volume is before and state.series.shown == state.series.index == 1
    assert not state.series.playing


def test_a_3d_volume_has_no_time_axis(viewer):
    viewer.open("sphere")
    assert not viewer.state.series.active
    with pytest.raises(ViewerError, match="one time point"):
        viewer.state.series.step(1)


# --- the real window under Xvfb --------------------------------------------------------------------
needs_xvfb = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")
READ_ROUNDS = 20   # of x_window's bounded frames: a read on the worker lands within a few, a loaded machine's later


def frames_until_read(window, condition) -> bool:
    return any(frames_until(window, condition) for _ in range(READ_ROUNDS))


@needs_xvfb
def test_the_window_steps_with_the_bracket_keys_and_records_a_movie(x_display, series, tmp_path):
    run_spawned(drive_window, x_display, series, tmp_path)
    import imageio.v2 as imageio
    reader = imageio.get_reader(tmp_path / "record.mp4", format="FFMPEG")   # ffmpeg reads it back
    try:
        count = reader.count_frames()
        assert count >= 10
        last = reader.get_data(count - 1).astype(int)
    finally:
        reader.close()
    assert last.shape == (240, 320, 3)
    # The panel (its title bar at the top left, from (8, 8)) is left out: the scene's background is there.
    from isoscope.viewer.model.style import SurfaceStyle
    background = 255 * np.array(SurfaceStyle().background)
    assert np.abs(last[10:20, 10:60] - background).max() <= 12   # within H.264's error
    # Framed as render frames it, centred in the whole frame: on screen the scene is centred in what the panel
    # leaves free, and the movie had an empty strip where the panel was.
    drawn = np.flatnonzero((np.abs(last - background).max(axis=2) > 40).any(axis=0))
    assert abs((drawn[0] + drawn[-1]) / 2 - 160) < 12, (drawn[0], drawn[-1])
    assert not list(tmp_path.glob(".record.mp4.*"))   # no partial file left


def drive_window(x_display, series, tmp_path):
    import os
    os.environ["DISPLAY"] = x_display
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow

    window = ViewerWindow(open_volume(series), size=(320, 240), screenshot_dir=tmp_path, recent=RecentFiles(None))
    try:
        state = window.state
        assert window.draw_frame()
        assert state.series.count == TIMES and state.series.shown == 0
        press_key(window, "bracketright")
        assert frames_until_read(window, lambda: state.series.shown == 1), state.error
        assert np.array_equal(state.volume.data, ball(1))
        press_key(window, "bracketleft")
        assert frames_until_read(window, lambda: state.series.shown == 0), state.error

        recorder = window.panel.time_section.recorder
        recorder.start(tmp_path / "record.mp4")
        state.series.toggle_play()
        assert frames_until_read(window, lambda: recorder.frames >= 10 and state.series.shown >= 2), state.error
        path = recorder.stop()
        assert path == tmp_path / "record.mp4", recorder.message
    finally:
        window.close()


def test_while_playing_the_time_label_names_the_time_point_drawn(viewer, any_series):
    """The label beside the slider named the time point asked for, a read ahead of the mesh on screen (9 of
    16 screenshots showed N over the mesh of N+1): it names the one whose samples are on show."""
    from isoscope.viewer.ui.panel import shown_notes
    from isoscope.viewer.ui.time_panel import time_text
    viewer.open(any_series)
    state, scene = viewer.state, viewer.scene
    assert not any("--time N" in note for note in shown_notes(state))   # the slider says which, not a stale note
    state.series.set_fps(30)
    state.series.toggle_play()
    for _ in range(40):
        scene.update(0.05)   # no waiting: reads finish when they finish, as in the window
        label = time_text(state.series)
        drawn = int(label.split()[0])
        assert np.array_equal(np.asarray(state.volume.data), ball(drawn)), label
    # The case that was wrong, made certain rather than left to the worker's speed (reads ahead often make the
    # wanted point ready in the same frame): a time point asked for and not yet taken by the GPU side.
    shown = state.series.shown
    state.series.go_to((shown + TIMES // 2) % TIMES)
    assert state.series.index != state.series.shown == shown
    label = time_text(state.series)
    assert int(label.split()[0]) == shown, label
    assert np.array_equal(np.asarray(state.volume.data), ball(shown)), label


def test_a_big_ome_zarr_series_shows_every_time_point_from_the_level_and_place_of_the_first(viewer, tmp_path):
    """Over the memory budget a t, z, y, x OME-Zarr series is shown from its level of 2^3 means, which the file
    translates by half a full sample (the blocks' centres): every time point, and going back to the first, is
    that level's samples at that place (Volume.origin), so a ball that stays put in time stays put on screen."""
    import zarr
    from support.ome_zarr import mean_levels, write_ome
    n, times = 64, 3
    grid = np.indices((n,) * 3, dtype=np.float64)
    still = (20.0 - np.sqrt(sum((g - 31.3) ** 2 for g in grid))).astype(np.float32)
    full, half = mean_levels(still, 2)
    axes = [{"name": "t", "type": "time"}] + [{"name": a, "type": "space"} for a in "zyx"]
    path = tmp_path / "still.ome.zarr"
    write_ome(path, [np.stack([full] * times), np.stack([half] * times)], [[1, 1, 1, 1], [1, 2, 2, 2]], axes=axes)
    group = zarr.open_group(str(path), mode="r+")
    multiscales = group.attrs["multiscales"]
    multiscales[0]["datasets"][1]["coordinateTransformations"].append(
        {"type": "translation", "translation": [0, 0.5, 0.5, 0.5]})
    group.attrs["multiscales"] = multiscales

    big = HeadlessViewer(SIZE, ctx=viewer.ctx, memory_budget="1M")
    try:
        big.state.style.show_box = False
        big.open(str(path))
        state = big.state
        assert state.series.count == times and state.step == 2
        assert state.volume.origin == (0.5, 0.5, 0.5) and np.array_equal(state.volume.data, half)
        first = big.render().astype(int)
        for index in (1, 2, 0):
            state.series.go_to(index)
            pixels = big.render().astype(int)
            assert state.series.shown == index
            assert state.volume.origin == (0.5, 0.5, 0.5), index
            assert np.array_equal(state.volume.data, half), index   # the level's means, not every 2nd sample
            assert np.abs(pixels - first).max() <= 2, index
    finally:
        big.release()


def test_the_recipe_of_a_coarse_view_names_its_own_level_in_a_pyramid_of_three(tmp_path):
    """A view of the coarsest of three mean levels is also 'every 2nd sample of the middle one' by spacing and
    shape: the recipe names the level it was read from (the middle one's every 2nd sample is other samples, at
    another place), and every 2nd sample of the coarsest is that level, step 2."""
    from support.ome_zarr import half_block_translations, mean_levels, with_translations, write_ome

    from isoscope.viewer.model.big_volume import every_step, from_level, shown_as, view_recipe
    data = np.random.default_rng(0).random((64,) * 3).astype(np.float32)
    path = tmp_path / "three.ome.zarr"
    write_ome(path, mean_levels(data, 3), [[2.0 ** k] * 3 for k in range(3)])
    volume = open_volume(str(with_translations(path, half_block_translations(3))))
    coarsest = volume.pyramid[-1]
    shown, step = from_level(volume, coarsest)
    assert view_recipe(volume, shown) == (coarsest.name, 1)
    again = shown_as(volume, view_recipe(volume, shown), step)
    assert again.origin == shown.origin and np.array_equal(np.asarray(again.data), np.asarray(shown.data))
    sparser = every_step(shown, 2)
    assert view_recipe(volume, sparser) == (coarsest.name, 2)
    assert view_recipe(volume, from_level(volume, volume.pyramid[0])[0]) == (volume.pyramid[0].name, 1)
