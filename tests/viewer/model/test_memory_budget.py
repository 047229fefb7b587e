"""The viewer's memory budget (issue 33, point 1 and 6): a volume is shown whole whenever it fits the budget
(the GPU's memory, half the RAM on llvmpipe, or --memory-budget / memory_budget=), every Nth sample otherwise;
what is on screen is said (`shown_shape`, the Stats line, the note), and a bad budget is one line."""
from __future__ import annotations

import numpy as np
import pytest
from support.command import isoscope_here

import isoscope
from isoscope.core.bricks import brick_layout
from isoscope.core.budget import (
    BudgetError,
    MemoryBudget,
    budget_step,
    default_budget,
    needed_bytes,
    parse_size,
    shown_shape,
)
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume


def ct_like(shape=(512, 512, 256)) -> np.ndarray:
    """A 512^2 x 256 uint8 scan (64 MiB): a body of soft tissue (100) around bones (220), air 0, in C order."""
    x = np.linspace(-1, 1, shape[0], dtype=np.float32)[:, None, None]
    y = np.linspace(-1, 1, shape[1], dtype=np.float32)[None, :, None]
    z = np.linspace(-1, 1, shape[2], dtype=np.float32)[None, None, :]
    body = (x / 0.85) ** 2 + (y / 0.6) ** 2 + 0 * z < 1
    bones = (np.sin(9 * x) * np.sin(7 * y) * np.cos(5 * z)) > 0.55
    scan = np.where(body, np.where(bones, 220, 100), 0).astype(np.uint8)
    return scan


def test_sizes_are_read_as_people_write_them():
    assert parse_size("2G") == 2 << 30 and parse_size("512M") == 512 << 20 and parse_size("1.5GiB") == 3 << 29
    assert parse_size("300MB") == 300 << 20 and parse_size(" 64m ") == 64 << 20 and parse_size("8000000") == 8000000
    assert parse_size(3 << 20) == 3 << 20
    for bad, words in (("abc", "is not a size"), ("-5G", "is not a size"), ("0", "below 1.0 MiB"),
                       ("1K", "below 1.0 MiB"), ("1e400", "is not a size"), (float("inf"), "more memory"),
                       (True, "is not a size"), ("\x1b[2J9G", "is not a size"), ("9" * 30, "more memory")):
        with pytest.raises(BudgetError) as error:
            parse_size(bad)
        assert words in str(error.value) and "\n" not in str(error.value) and "\x1b" not in str(error.value)
        assert isinstance(error.value, isoscope.IsoscopeError) and isinstance(error.value, ValueError)


def test_the_step_is_the_smallest_that_fits():
    shape = (512, 512, 400)
    budget = MemoryBudget(needed_bytes(shape, 2) * 4 // 3 + 1, "test")   # exactly room for the whole int16 CT
    assert budget_step(shape, 2, budget) == 1
    assert budget_step(shape, 4, budget) == 2              # the same CT as float32 needs twice... at step 2, 1/8
    smaller = MemoryBudget(budget.bytes // 9, "test")
    step = budget_step(shape, 2, smaller)
    assert needed_bytes(shape, 2, step) <= smaller.bytes * 0.75 < needed_bytes(shape, 2, step - 1)
    with pytest.raises(BudgetError, match=r"coarsest view of the volume \(2x2x300000 samples\) needs"):
        budget_step((2, 2, 300000), 4, MemoryBudget(1 << 20, "--memory-budget"))
    software = default_budget(None, software=True)
    assert software.bytes > 0 and "software renderer" in software.source
    assert default_budget(8 << 30, software=False, driver="GL_NVX_gpu_memory_info").bytes == int(0.8 * (8 << 30))
    assert default_budget(None, software=False).bytes == 2 << 30


@pytest.fixture(scope="module")
def ct():
    return ct_like()


@pytest.fixture
def viewer_with(gl_ctx):
    made = []

    def make(budget=None):
        made.append(HeadlessViewer((96, 72), ctx=gl_ctx, memory_budget=budget))
        return made[-1]
    yield make
    for viewer in made:
        viewer.release()


def test_a_512_class_scan_at_rest_is_shown_whole_with_export_s_faces(viewer_with, ct):
    """The old window drew a 512^2 x 256 scan at one sample in 2; with llvmpipe's budget (half the free RAM)
    it is shown whole, and the mesh on screen at rest is `export`'s (the API's outward mesh), face for face."""
    viewer = viewer_with()
    volume = as_volume(ct)
    viewer.show(volume, 160.0)
    state, scene = viewer.state, viewer.scene
    assert state.step == 1 and state.full_volume is None
    assert scene.stats.shown_shape == ct.shape and scene.stats.preview_step == 1
    verts, faces, _, _ = scene.surface.shown.read_mesh()
    want = isoscope.api.outward_marching_cubes(ct, 160.0)
    assert len(faces) > 100_000
    np.testing.assert_array_equal(faces, want[1])
    np.testing.assert_array_equal(verts, want[0])


def test_a_small_budget_shows_every_nth_sample_and_says_so(viewer_with, ct):
    viewer = viewer_with("16M")
    viewer.show(as_volume(ct), 160.0)
    state, scene = viewer.state, viewer.scene
    budget = MemoryBudget(16 << 20, "--memory-budget")
    # the coarse view of bricks (core/bricks.py): coarser than the budget's plain step, bricks refine it
    step = brick_layout(ct.shape, 1, budget).step
    assert step > budget_step(ct.shape, 1, budget) > 1 and state.step == step
    assert state.full_volume.data.shape == ct.shape
    assert scene.stats.shown_shape == shown_shape(ct.shape, step) == state.volume.data.shape
    np.testing.assert_array_equal(state.volume.data, ct[::step, ::step, ::step])
    note = [note for note in state.volume.notes if f"one sample in {step}" in note]
    assert note and "memory budget of 16.0 MiB (--memory-budget)" in note[0] and "--memory-budget SIZE" in note[0]
    # what is drawn is the subsampled scan's surface, at the full scan's place and size (to a step)
    assert state.bounds()[1] == tuple(float((n - 1) * step) for n in state.volume.data.shape)
    assert all(0 <= full - 1 - drawn < step for full, drawn in zip(ct.shape, state.bounds()[1]))


@pytest.mark.gl
def test_render_takes_a_budget_and_refuses_a_bad_one(ct):
    sphere = np.linalg.norm(np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j], axis=0).astype(np.float32)
    whole = isoscope.render(sphere, 0.6, size=(120, 90), gradient_direction="ascent")
    coarse = isoscope.render(sphere, 0.6, size=(120, 90), gradient_direction="ascent", memory_budget="1M")
    assert whole.shape == coarse.shape and not np.array_equal(whole, coarse)   # the same ball, fewer samples
    drawn = [(image[..., :3].astype(int) - whole[0, 0, :3]).any(axis=2) for image in (whole, coarse)]
    assert abs(int(drawn[0].sum()) - int(drawn[1].sum())) < 0.05 * drawn[0].sum()
    with pytest.raises(isoscope.IsoscopeError, match=r"^memory_budget 'lots' is not a size; give one like 2G"):
        isoscope.render(sphere, 0.6, memory_budget="lots")


@pytest.mark.gl
def test_the_command_takes_a_budget_and_refuses_a_bad_one_in_one_line(tmp_path):
    thin = tmp_path / "thin.npy"
    np.save(thin, np.random.default_rng(0).random((2, 2, 300_000)).astype(np.float32))
    for budget, words in (("junk", "--memory-budget 'junk' is not a size"),
                          ("1K", "--memory-budget '1K' is below 1.0 MiB"),
                          ("1M", "below what the coarsest view of thin.npy (2x2x300000 samples) needs")):
        done = isoscope_here("render", thin, "--iso", "0.5", "--out", tmp_path / "t.png", "--memory-budget", budget)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(lines) == 1 and words in lines[0], done.stderr
        assert not (tmp_path / "t.png").exists()
    done = isoscope_here("render", "torus", "--out", tmp_path / "t.png", "--memory-budget", "2M")
    assert done.returncode == 0 and (tmp_path / "t.png").stat().st_size > 0, done.stderr


def _pyramid(tmp_path, field, levels=3):
    """An OME-Zarr image (NGFF 0.4) whose levels are 2x2x2 means of the one above, as pyramid writers make
    them: not what striding the full level gives, so the level shown says where it was read from."""
    from support.ome_zarr import mean_levels, write_ome
    path = tmp_path / "pyramid.ome.zarr"
    group = write_ome(path, mean_levels(field, levels), [[0.5 * 2 ** level] * 3 for level in range(levels)], chunk=16)
    return path, [np.asarray(group[str(level)]) for level in range(levels)]


def test_an_ome_zarr_over_the_budget_is_shown_from_the_finest_level_that_fits(viewer_with, tmp_path):
    from scipy.ndimage import gaussian_filter

    from isoscope.volumes import open_volume
    field = gaussian_filter(np.random.default_rng(3).normal(size=(128, 128, 128)), 3).astype(np.float32)
    path, levels = _pyramid(tmp_path, field)
    volume = open_volume(str(path))
    assert [level.name for level in volume.pyramid] == ["1", "2"]
    assert [level.spacing for level in volume.pyramid] == [(1.0, 1.0, 1.0), (2.0, 2.0, 2.0)]
    viewer = viewer_with("8M")   # level 0 (128^3 float32) needs ~16 MB to show, level 1 ~1.5 MB (a quarter of
    # what 8M leaves beside the meshes: room for its bricks), level 2 0.2
    viewer.open(str(path))
    state = viewer.state
    assert state.full_volume.data.shape == (128, 128, 128) and state.volume.spacing == (1.0, 1.0, 1.0)
    np.testing.assert_array_equal(state.volume.data, levels[1])   # the file's level, not field[::2, ::2, ::2]
    assert not np.array_equal(levels[1], field[::2, ::2, ::2])
    assert state.step == 2 and state.bricks.layout.step == 2   # its bricks refined from level 0 at the open's
    assert viewer.scene.stats.shown_shape == (128, 128, 128)   # frame (test_pyramid_bricks.py)
    assert any("from its level '1'" in note for note in state.volume.notes)
    assert state.bounds()[1] == (63.0, 63.0, 63.0)   # the full level's extent (0.5 * 127), to a step
    tight = viewer_with("1M")   # only level 2 (32^3) fits
    tight.open(str(path))
    np.testing.assert_array_equal(tight.state.volume.data, levels[2])
    assert tight.state.volume.spacing == (2.0, 2.0, 2.0)


def test_a_volume_the_extractor_cannot_hold_is_shown_coarse_then_in_bricks_and_says_why(gl_ctx, monkeypatch):
    """llvmpipe's RAM budget lets a 1024^3 volume through, but its 128 MiB storage blocks do not (the window
    showed only an error); a shape the extractor refuses is shown at the smallest step it takes, and then its
    bricks in view at full resolution (extracted on the CPU a box at a time, which the limits do not bound)."""
    import isoscope.viewer.gfx.surface as surface_module
    from isoscope.gpu.limits import GpuLimits
    from isoscope.viewer.gfx.surface import extractor_refusal

    assert extractor_refusal(gl_ctx)((64, 64, 64)) is None
    said = extractor_refusal(gl_ctx)((1024, 1024, 1024))
    assert "storage-block limit" in said and ";" not in said   # the real limit, where the window met it
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 32 << 10)   # 64^3's row ranges: 64 KiB
    monkeypatch.setattr(surface_module.GpuLimits, "of", classmethod(lambda cls, ctx: small))
    viewer = HeadlessViewer((96, 72), ctx=gl_ctx, memory_budget="8G")
    try:
        data = np.random.default_rng(0).random((64, 64, 64)).astype(np.float32)
        viewer.show(as_volume(data), 0.5)
        state = viewer.state
        assert state.step == 2 and viewer.scene.stats.shown_shape == (32, 32, 32)
        np.testing.assert_array_equal(state.volume.data, data[::2, ::2, ::2])
        note = [note for note in state.volume.notes if "one sample in 2" in note]
        assert note and "to fit this GPU's limits" in note[0] and "32 KiB" not in note[0]
        assert "the bricks in view refined to full resolution within the memory budget of 8.0 GiB" in note[0]
        assert viewer.scene.stats.n_triangles > 0 and state.bricks is not None
        from isoscope.viewer.ui.headless import shown_note  # render's note: the limits, not the budget (8G)
        assert shown_note(viewer).startswith("the surface is drawn from 32x32x32 of 64x64x64 samples to fit this "
                                             "GPU's limits (")
        viewer.render()
        assert viewer.scene.stats.shown_shape == (64, 64, 64)
        assert state.bricks.text.startswith(f"{len(state.bricks.bricks)} of {len(state.bricks.bricks)} bricks")
        shown = sum(len(mesh.read()[1]) for mesh in viewer.scene.stats.meshes)
        assert shown == len(isoscope.api.outward_marching_cubes(data, 0.5)[1])
    finally:
        viewer.release()
