"""The viewer on a volume too big to drag live: a downsampled level on show with a note, and the
full-resolution mesh exported in a child process while the viewer keeps running (issue 12, part 5)."""
from __future__ import annotations

import time

import numpy as np
import pytest
import trimesh

import isoscope
from isoscope.viewer.gfx.state import ViewerState
from isoscope.viewer.model import big_volume
from isoscope.volumes import open_volume


@pytest.fixture
def big_npy(tmp_path, monkeypatch):
    """A 61^3 gyroid on disk, memory-mapped when opened; the viewer's budget lowered so it counts as big."""
    axis = np.linspace(0, 4 * np.pi, 61, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    path = tmp_path / "big.npy"
    np.save(path, np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x))
    monkeypatch.setattr(big_volume, "VIEWER_MAX_VOXELS", 25 ** 3)
    return path


@pytest.fixture
def state(gl_ctx):
    state = ViewerState(gl_ctx)
    yield state
    state.release()


def wait_for_export(state, seconds) -> int:
    """Frames of `state.update` until the running export is over (or `seconds` pass); their count."""
    frames, deadline = 0, time.monotonic() + seconds
    while state.exporting is not None and time.monotonic() < deadline:
        state.update(0.02)          # the viewer keeps drawing frames meanwhile
        frames += 1
        time.sleep(0.02)
    return frames


def test_a_big_volume_is_shown_downsampled_with_a_note(state, big_npy):
    full = np.load(big_npy)
    assert state.open(str(big_npy))
    assert state.full_volume is not None and state.full_volume.data.shape == (61, 61, 61)
    assert state.volume.data.shape == (21, 21, 21)               # every 3rd sample: 21^3 <= 25^3
    np.testing.assert_array_equal(state.volume.data, full[::3, ::3, ::3])
    assert state.volume.spacing == (3.0, 3.0, 3.0)
    assert state.bounds() == ((0, 0, 0), (60.0, 60.0, 60.0))     # the full volume's box
    assert any("one sample in 3" in note for note in state.volume.notes)
    assert state.n_triangles > 0


@pytest.mark.parametrize("inside_below", [False, True])
def test_the_full_resolution_export_runs_in_the_background_and_matches_the_api(state, big_npy, tmp_path,
                                                                               inside_below):
    assert state.open(str(big_npy))
    state.set_inside_below(inside_below)   # the side chosen in the panel reaches the export
    state.set_iso(0.3)
    state.update(0.0)
    out = tmp_path / "full.ply"
    assert state.export_full_resolution(out)
    assert not state.export_full_resolution(tmp_path / "again.ply") and "still running" in state.error
    frames = wait_for_export(state, 120)
    assert state.exporting is None and state.error is None and "wrote" in state.message
    assert frames > 1
    mesh = trimesh.load(out, process=False)
    expected = isoscope.marching_cubes(np.load(big_npy), 0.3,
                                       gradient_direction="ascent" if inside_below else "descent")
    assert len(mesh.faces) == len(expected[1]) and len(mesh.vertices) == len(expected[0])
    np.testing.assert_array_equal(mesh.faces, expected[1])   # the same winding: the same side out


def test_a_failed_export_is_one_line_in_the_panel_and_leaves_no_file(state, big_npy, tmp_path):
    assert state.open(str(big_npy))
    out = tmp_path / "no-such-folder" / "full.ply"
    assert state.export_full_resolution(out)
    wait_for_export(state, 60)
    assert state.error.startswith("full-resolution export failed") and "\n" not in state.error
    assert not out.exists() and not out.parent.exists()


def test_a_small_volume_is_shown_whole(state):
    assert state.show(open_volume("torus"))
    assert state.full_volume is None
    assert not state.export_full_resolution("x.ply") and "Save mesh" in state.error


def test_colour_by_a_second_big_volume_of_the_full_shape(state, big_npy, tmp_path):
    assert state.open(str(big_npy))
    partner = tmp_path / "dose.npy"
    np.save(partner, np.random.default_rng(3).random((61, 61, 61)).astype(np.float32))
    assert state.set_color_by(str(partner)), state.error
    assert state.color_by.scalar_texture.size == (21, 21, 21)   # downsampled like the volume on show
    np.save(partner, np.random.default_rng(4).random((60, 61, 61)).astype(np.float32))
    assert not state.set_color_by(str(partner)) and "same shape" in state.error


def test_the_export_reopens_a_raw_file_with_the_options_it_was_opened_with(state, big_npy, tmp_path):
    data = np.load(big_npy)
    raw = tmp_path / "big.raw"
    data.tofile(raw)                    # headerless: only --dims and --dtype say what it is
    assert state.open(str(raw), dims=(61, 61, 61), dtype="float32"), state.error
    assert state.full_volume.open_options == {"dims": (61, 61, 61), "dtype": "float32"}
    state.set_iso(0.3)
    out = tmp_path / "raw.ply"
    assert state.export_full_resolution(out)
    wait_for_export(state, 120)
    assert state.error is None, state.error
    full = state.full_volume.checked.data
    assert len(trimesh.load(out, process=False).faces) == len(isoscope.marching_cubes(full, 0.3)[1])
