"""The viewer on a volume too big to drag live: a downsampled level on show with a note, and the
full-resolution mesh exported in a child process while the viewer keeps running (issue 12, part 5)."""
from __future__ import annotations

import time

import numpy as np
import pytest
import trimesh

import isoscope
from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume


@pytest.fixture
def big_npy(tmp_path):
    """A 61^3 float32 gyroid on disk (900 KB), memory-mapped when opened."""
    axis = np.linspace(0, 4 * np.pi, 61, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    path = tmp_path / "big.npy"
    np.save(path, np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x))
    return path


@pytest.fixture
def viewer(gl_ctx):
    """A viewer whose memory budget, 1 MiB, takes the 61^3 float32 gyroid at every other sample: whole, with its
    previews (1.2 x 4.75 bytes a sample, core/budget.py), it needs 1.7 MiB; at step 2 (31^3), 0.22 MiB."""
    viewer = HeadlessViewer((64, 64), ctx=gl_ctx, memory_budget="1M")
    yield viewer
    viewer.release()


def wait_for_export(viewer, seconds) -> int:
    """Frames of the scene's update until the running export is over (or `seconds` pass); their count."""
    frames, deadline, state = 0, time.monotonic() + seconds, viewer.state
    while state.saving.exporting is not None and time.monotonic() < deadline:
        viewer.scene.update(0.02)          # the viewer keeps drawing frames meanwhile
        frames += 1
        time.sleep(0.02)
    return frames


def test_a_big_volume_is_shown_downsampled_with_a_note(viewer, big_npy):
    full = np.load(big_npy)
    viewer.open(str(big_npy))
    state = viewer.state
    assert state.full_volume is not None and state.step == 2 and state.full_volume.data.shape == (61, 61, 61)
    assert state.volume.data.shape == (31, 31, 31)               # every 2nd sample
    np.testing.assert_array_equal(state.volume.data, full[::2, ::2, ::2])
    assert state.volume.spacing == (2.0, 2.0, 2.0)
    assert state.bounds() == ((0, 0, 0), (60.0, 60.0, 60.0))     # the full volume's box
    note = [note for note in state.volume.notes if "one sample in 2" in note]
    assert note and "memory budget of 1.0 MiB (--memory-budget)" in note[0]
    assert viewer.scene.stats.n_triangles > 0


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_the_full_resolution_export_runs_in_the_background_and_matches_the_api(viewer, big_npy, tmp_path,
                                                                               direction):
    viewer.open(str(big_npy))
    state = viewer.state
    state.set_gradient_direction(direction)   # the side chosen in the panel reaches the export
    state.iso = 0.3
    viewer.scene.update(0.0)
    out = tmp_path / "full.ply"
    state.saving.export_full_resolution(out)
    with pytest.raises(ViewerError, match="still running"):
        state.saving.export_full_resolution(tmp_path / "again.ply")
    frames = wait_for_export(viewer, 120)
    assert state.saving.exporting is None and state.error is None and "wrote" in state.message
    assert frames > 1
    mesh = trimesh.load(out, process=False)
    expected = isoscope.api.outward_marching_cubes(np.load(big_npy), 0.3, gradient_direction=direction)
    assert len(mesh.faces) == len(expected[1]) and len(mesh.vertices) == len(expected[0])
    np.testing.assert_array_equal(mesh.faces, expected[1])   # the same winding: the same side out


def test_the_full_resolution_export_has_the_topology_on_show(viewer, tmp_path):
    """The Mesh section's topology reaches the file (it was written with montani's, whatever was shown)."""
    noise = np.random.default_rng(7).standard_normal((61, 61, 61)).astype(np.float32)   # ambiguous everywhere
    np.save(tmp_path / "noise.npy", noise)
    viewer.open(str(tmp_path / "noise.npy"))
    state = viewer.state
    assert state.full_volume is not None
    state.iso = 0.0
    assert state.set_topology("trilinear")
    viewer.scene.update(0.0)
    state.saving.export_full_resolution(tmp_path / "trilinear.ply")
    wait_for_export(viewer, 120)
    assert state.error is None, state.error
    trilinear, montani = (isoscope.api.outward_marching_cubes(noise, 0.0, topology=topology)
                          for topology in ("trilinear", "montani"))
    assert len(trilinear[1]) != len(montani[1])
    np.testing.assert_array_equal(trimesh.load(tmp_path / "trilinear.ply", process=False).faces, trilinear[1])


def test_a_failed_export_is_one_line_in_the_panel_and_leaves_no_file(viewer, big_npy, tmp_path):
    viewer.open(str(big_npy))
    state = viewer.state
    out = tmp_path / "no-such-folder" / "full.ply"
    state.saving.export_full_resolution(out)
    wait_for_export(viewer, 60)
    assert state.error.startswith("full-resolution export failed") and "\n" not in state.error
    assert not out.exists() and not out.parent.exists()


def test_a_small_volume_is_shown_whole(gl_ctx):
    viewer = HeadlessViewer((64, 64), ctx=gl_ctx)   # this GL's own budget: half the RAM on llvmpipe
    try:
        viewer.show(open_volume("torus"))
        assert viewer.state.full_volume is None and viewer.state.step == 1
        with pytest.raises(ViewerError, match="Save mesh"):
            viewer.state.saving.export_full_resolution("x.ply")
    finally:
        viewer.release()


def test_colour_by_a_second_big_volume_of_the_full_shape(viewer, big_npy, tmp_path):
    viewer.open(str(big_npy))
    state = viewer.state
    partner = tmp_path / "dose.npy"
    np.save(partner, np.random.default_rng(3).random((61, 61, 61)).astype(np.float32))
    state.set_color_by(str(partner))
    viewer.update()
    assert viewer.scene.color_by.scalar_texture.size == (31, 31, 31)   # downsampled like the volume on show
    np.save(partner, np.random.default_rng(4).random((60, 61, 61)).astype(np.float32))
    with pytest.raises(ValueError, match="same shape"):
        state.set_color_by(str(partner))


def test_the_export_reopens_a_raw_file_with_the_options_it_was_opened_with(viewer, big_npy, tmp_path):
    data = np.load(big_npy)
    raw = tmp_path / "big.raw"
    data.tofile(raw)                    # headerless: only --dims and --dtype say what it is
    viewer.open(str(raw), dims=(61, 61, 61), dtype="float32")
    state = viewer.state
    assert state.full_volume.open_options == {"dims": (61, 61, 61), "dtype": "float32"}
    state.iso = 0.3
    out = tmp_path / "raw.ply"
    state.saving.export_full_resolution(out)
    wait_for_export(viewer, 120)
    assert state.error is None, state.error
    full = state.full_volume.checked.data
    assert len(trimesh.load(out, process=False).faces) == len(isoscope.marching_cubes(full, 0.3)[1])


def test_a_stopped_export_writes_nothing(viewer, tmp_path):
    """The export runs in this process on a worker thread (the library's big/export.py, no child process);
    stopping it, as closing the window does, ends it before its file is written."""
    axis = np.linspace(0, 8 * np.pi, 200, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    path = tmp_path / "gyroid200.npy"
    np.save(path, np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x))
    viewer.open(str(path))
    state = viewer.state
    assert state.step > 1
    out = tmp_path / "full.ply"
    state.saving.export_full_resolution(out)
    state.saving._export.cancel()
    wait_for_export(viewer, 60)
    assert state.error is not None and "stopped" in state.error and "\n" not in state.error
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["gyroid200.npy"]
