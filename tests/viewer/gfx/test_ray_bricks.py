"""A volume over the memory budget ray cast brick by brick (issue 37): the bricks in view are read at full
resolution into an atlas, nearest first, as many as the room holds, and the rays read them there and the
coarse view elsewhere (model/ray_bricks.py, gfx/ray_atlas.py, shaders/raycast.frag BRICKED)."""
from __future__ import annotations

import itertools
import math
import os
import re
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from isoscope.core.value_ranges import brick_ranges, ranges_within, widened
from isoscope.viewer.model.ray_bricks import slot_grid
from isoscope.viewer.model.raycast import rays_note
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume

N = 160
BUDGET = "8M"   # the whole (160^3 uint8) needs 8.6 MiB to show; the coarse view at step 2 and 15 slots of 65^3 fit
SIZE = (320, 240)


@pytest.fixture(scope="module")
def lines() -> np.ndarray:
    """A dim box with bright lines one sample thick at odd indices: every 2nd sample (the coarse view) has none
    of them, so a picture of the coarse view alone misses them."""
    data = np.zeros((N, N, N), np.uint8)
    data[20:140, 20:140, 20:140] = 40
    for k in range(25, 135, 10):
        data[k, 20:140, 81] = 250
        data[41, k, 20:140] = 200
        data[20:140, 61, k] = 150
    return data


# --- pure parts --------------------------------------------------------------------------------------
def test_the_ranges_of_parts_taken_into_nothing_are_the_ranges_of_the_whole():
    """ranges_within of bricks sharing their faces' samples (cut anywhere, not at range-brick boundaries),
    widened into an empty start, are brick_ranges of the whole; a part reaching past the last range brick
    counts in it."""
    data = np.random.default_rng(1).random((70, 61, 53)).astype(np.float32)
    whole = brick_ranges(data, 16)
    for index in np.ndindex(whole.shape[:3]):   # each brick's samples, its far faces' included
        samples = data[tuple(slice(16 * i, 16 * i + 17) for i in index)]
        assert tuple(whole[index]) == (samples.min(), samples.max())
    empty = np.stack([np.full(whole.shape[:3], np.inf), np.full(whole.shape[:3], -np.inf)], -1).astype(np.float32)
    cuts = [(0, 30, 69), (0, 20, 60), (0, 50, 52)]
    parts = []
    for corner in itertools.product(range(2), repeat=3):
        first = [cuts[axis][i] for axis, i in enumerate(corner)]
        part = data[tuple(slice(cuts[axis][i], cuts[axis][i + 1] + 1) for axis, i in enumerate(corner))]
        parts.append(ranges_within(part, first, 16))
    np.testing.assert_array_equal(widened(empty, parts), whole)
    # the ranges of a coarser count: the last brick along each axis takes what lies past it
    clamped = widened(empty[:4, :3, :3], parts)
    assert clamped[3, 2, 2, 1] == data[48:, 32:, 32:].max() and clamped[3, 2, 2, 0] == data[48:, 32:, 32:].min()


@pytest.mark.parametrize("shift", [(0.5, 1.5, -0.25), (3.5, 0.5, 7.5), (1.0, 0.0, 2.0)])
def test_a_shifted_brick_s_range_covers_every_sample_a_ray_inside_it_reads(shift):
    """A coarse view off the full grid (a pyramid level's offset, `shift` full samples): the full bricks' parts
    (cut anywhere, sharing their faces' samples) widened into its bricks of 16 full cells a side, which start
    at `shift`, give each of them the (min, max) of every full sample whose cell reaches into it (the first and
    last take what lies before and past them): a ray skipping one skips no sample it should read.  Exactly
    those where the shift falls between samples; at least those where it falls on them (a hair wider)."""
    data = np.random.default_rng(2).random((70, 61, 53)).astype(np.float32)
    size, counts = 16, (4, 3, 3)
    empty = np.stack([np.full(counts, np.inf), np.full(counts, -np.inf)], -1).astype(np.float32)
    cuts = [(0, 30, 69), (0, 20, 60), (0, 50, 52)]
    parts = []
    for corner in itertools.product(range(2), repeat=3):
        first = [cuts[axis][i] for axis, i in enumerate(corner)]
        part = data[tuple(slice(cuts[axis][i], cuts[axis][i + 1] + 1) for axis, i in enumerate(corner))]
        parts.append(ranges_within(part, first, size, shift))
    ranges = widened(empty, parts)
    exact = all(float(s) != int(s) for s in shift)
    for index in np.ndindex(counts):
        reach = []
        for b, s, n, c in zip(index, shift, data.shape, counts):
            low = 0 if b == 0 else math.floor(b * size + s)
            high = n - 1 if b == c - 1 else min(math.ceil((b + 1) * size + s), n - 1)
            reach.append(slice(low, high + 1))
        samples = data[tuple(reach)]
        assert ranges[index][0] <= samples.min() and ranges[index][1] >= samples.max(), (index, shift)
        if exact:
            assert tuple(ranges[index]) == (samples.min(), samples.max()), (index, shift)
    # folded where the full grid's bricks lie (unshifted, as before): some shifted brick lacks samples in it
    unshifted = widened(empty, [ranges_within(data, (0, 0, 0), size)])
    assert np.any(unshifted[..., 1] < ranges[..., 1]) or np.any(unshifted[..., 0] > ranges[..., 0])


def test_the_atlas_has_the_most_slots_the_room_and_its_sides_allow():
    for slots, per_axis in itertools.product(range(0, 130), (1, 2, 3, 5, 15)):
        grid = slot_grid(slots, per_axis)
        best = max((a * b * c for a, b, c in itertools.product(range(per_axis + 1), repeat=3) if a * b * c <= slots),
                   default=0)
        assert math.prod(grid) == best and max(grid) <= per_axis, (slots, per_axis, grid)


# --- on the GPU --------------------------------------------------------------------------------------
def _pictured(gl_ctx, volume, budget, mode, level=100.0, with_surfaces=False):
    """The viewer after a picture of `volume` ray cast in `mode`, the camera close to the box's corner at the
    origin (so a part of the bricks is in view), and the picture."""
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx, memory_budget=budget)
    viewer.show(volume, level, 30.0, 25.0)
    viewer.camera.fit((0.0, 0.0, 0.0), (N - 1.0,) * 3, 30.0, 25.0)
    viewer.camera.target = np.array([45.0, 45.0, 45.0])
    viewer.camera.distance = 120.0
    viewer.state.set_raycast(mode)
    viewer.state.set_with_surfaces(with_surfaces)
    viewer.state.slices.set_window(*((100.0, 150.0) if mode == "dvr" else (255.0, 127.5)))   # DVR: lines opaque
    return viewer, viewer.picture().astype(int)


@pytest.mark.parametrize("mode, tolerance, seen", [("mip", 1, 60), ("dvr", 2, 10), ("iso", 2, 60)])
def test_the_bricks_in_view_are_ray_cast_at_full_resolution(gl_ctx, lines, mode, tolerance, seen):
    """With every brick in view read, the picture is the whole volume's (shown whole, no budget) at the same
    camera, but for a thousandth of its pixels by more than `tolerance`; the coarse view alone (every 2nd
    sample, shown whole) misses the lines: thousands of pixels differ by more than `seen` (DVR's thin lines are
    faint through its ramp)."""
    level = 120.0 if mode == "iso" else 100.0
    viewer, bricked = _pictured(gl_ctx, as_volume(lines, name="lines"), BUDGET, mode, level)
    try:
        rays = viewer.state.bricks.rays
        coarse = viewer.state.volume
        assert viewer.state.step == 2 and 0 < rays.capacity < 27
        assert rays.visible and rays.visible <= set(rays.loaded) and len(rays.visible) < 27
        assert all(brick.samples is None for brick in rays.loaded.values())   # in the atlas, let go here
    finally:
        viewer.release()
    whole_viewer, whole = _pictured(gl_ctx, as_volume(lines, name="lines"), None, mode, level)
    whole_viewer.release()
    coarse_viewer, coarse_only = _pictured(gl_ctx, as_volume(coarse.data, spacing=coarse.spacing, name="lines"),
                                           None, mode, level)
    coarse_viewer.release()
    difference = np.abs(bricked - whole).max(axis=2)
    assert np.count_nonzero(difference > tolerance) <= 0.001 * difference.size, (difference.max(),
                                                                               np.count_nonzero(difference > tolerance))
    assert np.count_nonzero(np.abs(coarse_only - whole).max(axis=2) > seen) > 2000   # what the bricks add
    assert whole.std() > 10


@pytest.mark.parametrize("mode", ["mip", "iso", "dvr"])
def test_skipping_in_bricks_changes_no_pixel(gl_ctx, lines, monkeypatch, mode):
    """The picture of the volume in bricks with its skipping ranges (the coarse view's, widened by what the
    bricks read in full hold, and each brick's own of 8^3 full cells) equals the one with nothing skippable."""
    import isoscope.viewer.gfx.ray_atlas as ray_atlas
    import isoscope.viewer.gfx.raycast as raycast
    import isoscope.viewer.model.ray_bricks as ray_bricks
    level = 120.0 if mode == "iso" else 100.0
    pictures = []
    for brick, macro in ((10**6, 1), (8, 4)):
        for module in (raycast, ray_bricks, ray_atlas):
            monkeypatch.setattr(module, "RANGE_BRICK" if module is not raycast else "BRICK", brick)
        monkeypatch.setattr(raycast, "MACRO", macro)
        viewer, picture = _pictured(gl_ctx, as_volume(lines, name="lines"), BUDGET, mode, level)
        assert viewer.state.bricks.rays.loaded
        viewer.release()
        pictures.append(picture)
    assert np.abs(pictures[1] - pictures[0]).max() <= 1
    assert pictures[0].std() > 10


@pytest.fixture(scope="module")
def smooth() -> np.ndarray:
    """A smooth bright blob with a dimmer rim, 161^3 uint8 (its coarse view's every 2nd sample spans the same box):
    the coarse view's interpolant is within a fraction of a value of the full one's."""
    axis = np.arange(161, dtype=np.float64)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij", sparse=True)
    r2 = (x - 70) ** 2 + (y - 85) ** 2 + (z - 80) ** 2
    return np.clip(230 * np.exp(-r2 / (2 * 28.0**2)) + 20 * np.sin(x / 25) * np.cos(z / 30), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("mode", ["mip", "mean", "dvr", "iso"])
def test_with_part_of_the_bricks_read_the_rest_is_ray_cast_from_the_coarse_view(gl_ctx, smooth, mode):
    """More bricks in view than the room holds: the picture, part full resolution and part coarse view (in one
    box: the coarse view's), is the whole volume's within 2 levels but for a thousandth of its pixels (the
    field is smooth: the two interpolants differ by a fraction of a value), in every mode: the mean weighs each
    sample by the length of its step (the coarse view's are longer)."""
    pictures = []
    for budget in (BUDGET, None):
        viewer = HeadlessViewer(SIZE, ctx=gl_ctx, memory_budget=budget)
        try:
            viewer.show(as_volume(smooth, name="smooth"), 150.0, 30.0, 25.0)
            viewer.state.set_raycast(mode)
            viewer.state.slices.set_window(*((120.0, 160.0) if mode == "dvr" else (255.0, 127.5)))
            pictures.append(viewer.picture().astype(int))
            if budget is not None:
                rays = viewer.state.bricks.rays
                assert rays.loaded and rays.visible - set(rays.loaded)   # some bricks in view are coarse
        finally:
            viewer.release()
    difference = np.abs(pictures[0] - pictures[1]).max(axis=2)
    assert np.count_nonzero(difference > 2) <= 0.001 * difference.size, (difference.max(),
                                                                         np.count_nonzero(difference > 2))
    assert pictures[1].std() > 10


def test_a_brick_that_cannot_be_read_is_said_once_and_the_others_still_come(gl_ctx, lines, monkeypatch):
    import isoscope.viewer.model.ray_bricks as ray_bricks
    reads, read = [], ray_bricks.read_ray_brick

    def failing(data, brick, *args, **kwargs):
        reads.append(brick.index)
        if brick.index == (0, 0, 0):
            raise OSError("a damaged chunk")
        return read(data, brick, *args, **kwargs)
    monkeypatch.setattr(ray_bricks, "read_ray_brick", failing)
    viewer, _ = _pictured(gl_ctx, as_volume(lines, name="lines"), BUDGET, "mip")
    try:
        rays = viewer.state.bricks.rays
        assert viewer.state.error == "a damaged chunk"
        assert rays.failed == {(0, 0, 0)} and (0, 0, 0) not in rays.loaded
        viewer.state.error = None
        for _ in range(3):   # the window's frames: not asked again, the others read
            viewer.app.follow(0.02)
        viewer.render()
        assert reads.count((0, 0, 0)) == 1 and viewer.state.error is None and len(rays.loaded) > 1
        viewer.state.set_raycast(None)   # the rays off and on again: the brick is asked for again
        viewer.render()
        viewer.state.set_raycast("mip")
        viewer.render()
        assert reads.count((0, 0, 0)) == 2 and rays.failed == {(0, 0, 0)}
    finally:
        viewer.release()


def test_ray_bricks_come_from_a_worker_share_the_room_with_surfaces_and_go_with_the_rays(gl_ctx, lines):
    viewer, _ = _pictured(gl_ctx, as_volume(lines, name="lines"), BUDGET, "mip")
    try:
        state, app = viewer.state, viewer.app
        rays = state.bricks.rays
        alone = rays.capacity
        note = rays_note(state)
        assert note.startswith("the volume is ray cast at full resolution in its bricks read so far, "
                               f"{len(rays.loaded)} of 27 bricks at full resolution")
        assert "and from 80x80x80 of 160x160x160 samples elsewhere" in note
        # with the surfaces too: the rays have half the room, the surfaces' bricks the rest
        state.set_with_surfaces(True)
        viewer.render()
        assert 0 < rays.capacity < alone and len(rays.loaded) <= rays.capacity
        assert state.bricks.meshes   # the surfaces are refined beside
        # a window's frames: a brick at a time from the worker, never waiting
        state.set_with_surfaces(False)
        counts, deadline = [], time.monotonic() + 120
        while not counts or rays.to_load or rays.reading is not None:
            app.follow(0.02)
            viewer.target.use()
            app.draw(viewer.target.viewport)
            counts.append(len(rays.loaded))
            assert time.monotonic() < deadline
        assert counts[0] == 0 and all(b - a <= 1 for a, b in zip(counts, counts[1:])) and counts[-1] > 1
        # no rays: the bricks and the atlas are let go, and the meshes have the whole room again
        state.set_raycast(None)
        viewer.render()
        assert rays.capacity == 0 and not rays.loaded and app.renderer._raycaster._atlas is None
        assert rays_note(state) is None
    finally:
        viewer.release()


@pytest.mark.gl   # render needs a GL context
@pytest.mark.parametrize("mode", ["mip", "iso"])
def test_render_ray_casts_bricks_on_opengl_41_as_on_43_and_says_how_many(lines, tmp_path, mode):
    """`render --raycast` of a volume over the budget: the same picture on OpenGL 4.1 (macOS) as on 4.3, the
    bricks in view read in full (the lines show), and a note saying how many."""
    np.save(tmp_path / "lines.npy", lines)
    plain = {k: v for k, v in os.environ.items() if not k.startswith("MESA_GL")}
    old_gl = {**plain, "MESA_GL_VERSION_OVERRIDE": "4.1", "MESA_GLSL_VERSION_OVERRIDE": "410"}
    pictures = {}
    for name, environment in (("41", old_gl), ("43", plain)):
        done = subprocess.run([sys.executable, "-m", "isoscope", "render", tmp_path / "lines.npy", "--raycast", mode,
                               "--iso", "120", "--window", "255", "--level", "127.5", "--memory-budget", BUDGET,
                               "--size", "320x240", "--out", tmp_path / f"{name}.png"], env=environment,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        # rays alone: no surface note
        notes = [line for line in done.stderr.splitlines() if line.startswith("note: ")]
        assert len(notes) == 1 and re.match(r"note: the volume is ray cast at full resolution in its bricks read so "
                                            r"far, \d+ of 27 bricks", notes[0]), done.stderr
        pictures[name] = np.asarray(Image.open(tmp_path / f"{name}.png")).astype(int)
    assert np.abs(pictures["41"] - pictures["43"]).max() <= 2
    assert np.count_nonzero(pictures["43"].max(axis=2) >= 120) > 300   # the lines (150 to 250) are drawn
