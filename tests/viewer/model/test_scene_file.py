"""Scenes (issue 26): a render saved with --save-scene is redrawn pixel for pixel from the JSON, the window
reopens it, the model round-trips it without GL, and a bad scene is one line."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image
from support.command import assert_one_line_error, isoscope, isoscope_here

from isoscope.viewer.model.camera import OrbitCamera
from isoscope.viewer.model.scene_file import SceneError, apply_scene, read_scene, scene_of
from isoscope.viewer.model.state import ViewerState
from isoscope.volumes import open_volume

VIEW = ("--iso", "100", "--iso", "170", "--opacity", "0.4,1", "--slice", "z=32", "--clip", "x=30", "--colormap",
        "viridis", "--window", "150", "--level", "90", "--azimuth", "40", "--elevation", "10", "--size", "320x240")


def pixels(path):
    return np.asarray(Image.open(path))


@pytest.mark.gl
def test_a_saved_scene_redraws_the_same_picture(tmp_path):
    for name, extra in (("plain", ()), ("coloured", ("--color-by", "gradient", "--color-by-map", "magma"))):
        first = isoscope_here("render", "bucky", *VIEW, *extra, "--out", tmp_path / f"{name}.png",
                              "--save-scene", tmp_path / f"{name}.json")
        assert first.returncode == 0, first.stderr
        again = isoscope_here("render", tmp_path / f"{name}.json", "--out", tmp_path / f"{name}2.png")
        assert again.returncode == 0, again.stderr
        assert np.array_equal(pixels(tmp_path / f"{name}.png"), pixels(tmp_path / f"{name}2.png")), name
    scene = json.loads((tmp_path / "plain.json").read_text())
    assert scene["format"] == "isoscope-scene" and scene["version"] == 1 and scene["size"] == [320, 240]
    assert [level["value"] for level in scene["levels"]] == [100.0, 170.0]
    assert scene["slices"]["clip"] == {"axis": 0, "position": 30.0, "hide_above": True}
    bigger = isoscope_here("render", tmp_path / "plain.json", "--size", "640x480", "--out", tmp_path / "big.png")
    assert bigger.returncode == 0 and pixels(tmp_path / "big.png").shape == (480, 640, 3)


@pytest.mark.gl
def test_the_window_opens_a_scene(tmp_path, x_display, monkeypatch):
    monkeypatch.setenv("DISPLAY", x_display)
    assert isoscope_here("render", "torus", "--iso", "0.1", "--out", tmp_path / "t.png", "--save-scene",
                         tmp_path / "t.json").returncode == 0
    result = isoscope(tmp_path / "t.json", "--frames", "2")
    assert result.returncode == 0, result.stderr


def test_the_model_round_trips_a_scene_without_gl():
    volume = open_volume("bucky")
    state, camera = ViewerState(), OrbitCamera()
    state.show(volume, 90.0)
    state.levels.add(150.0)
    state.levels.set_opacity(1, 0.5)
    state.set_smooth(2)
    state.slices.show(1, True, 20)
    state.slices.set_clip(2, 40.0, hide_above=False)
    camera.azimuth, camera.elevation = 123.0, -30.0
    scene = json.loads(json.dumps(scene_of(state, camera, (400, 300))))   # through JSON text
    other, other_camera = ViewerState(), OrbitCamera()
    other.show(volume)
    apply_scene(scene, other, other_camera)
    assert [(item.value, item.opacity) for item in other.levels.items] == [(90.0, 1.0), (150.0, 0.5)]
    assert other.levels.selected == state.levels.selected and other.mesh_options == state.mesh_options
    assert other.slices.shown == [False, True, False] and other.slices.index[1] == 20
    assert (other.slices.clip.axis, other.slices.clip.position, other.slices.clip.hide_above) == (2, 40.0, False)
    assert (other_camera.azimuth, other_camera.elevation) == (123.0, -30.0)
    scene["levels"][0]["value"] = 9999.0
    fresh = ViewerState()
    fresh.show(volume)
    with pytest.raises(SceneError, match="outside the volume's value range"):
        apply_scene(scene, fresh, OrbitCamera())


@pytest.mark.gl   # held to what `isoscope render` says: it needs a GL context first
def test_bad_scenes_are_one_line(tmp_path):
    good = {"format": "isoscope-scene", "version": 1, "volume": {"source": str(tmp_path / "gone.nii.gz")},
            "levels": [{"value": 1.0}],
            "camera": {"azimuth": 0.0, "elevation": 0.0, "distance": 5.0, "target": [0, 0, 0]}}
    cases = {
        "gone.json": (good, ("gone.nii.gz", "not there any more")),
        "future.json": ({**good, "version": 7}, ("version 7", "save it again")),
        "other.json": ({"format": "something else"}, ("not an isoscope scene",)),
    }
    for name, (content, words) in cases.items():
        (tmp_path / name).write_text(json.dumps(content))
        with pytest.raises(SceneError):
            read_scene(tmp_path / name)
        assert_one_line_error(isoscope_here("render", tmp_path / name, "--out", tmp_path / "x.png"), *words)
    (tmp_path / "broken.json").write_text("{not json")
    assert_one_line_error(isoscope_here("render", tmp_path / "broken.json", "--out", tmp_path / "x.png"),
                          "not JSON")
    saved = isoscope_here("render", "torus", "--out", tmp_path / "t.png", "--save-scene", tmp_path / "t.json")
    assert saved.returncode == 0, saved.stderr
    assert_one_line_error(isoscope_here("render", tmp_path / "t.json", "--iso", "0", "--out", tmp_path / "x.png"),
                          "a scene holds the view", "--iso")
    assert not (tmp_path / "x.png").exists()


def test_the_viewer_opens_a_scene_where_it_opens_a_volume(tmp_path, gl_ctx):
    """Open file (and a drop, and Recent) go through state.opening.open: a scene opens its volume on the
    worker, then its levels, slices and camera are put on it; a bad scene is its one line."""
    from isoscope.viewer.ui.headless import HeadlessViewer
    saved = isoscope_here("render", "bucky", *VIEW, "--out", tmp_path / "a.png", "--save-scene", tmp_path / "a.json")
    assert saved.returncode == 0, saved.stderr
    viewer = HeadlessViewer((320, 240), ctx=gl_ctx)
    try:
        viewer.open(str(tmp_path / "a.json"))
        state = viewer.state
        assert [level.value for level in state.levels.items] == [100.0, 170.0]
        assert (viewer.camera.azimuth, viewer.camera.elevation) == (40.0, 10.0)
        assert state.slices.shown[2] and state.slices.index[2] == 32
        assert str(tmp_path / "a.json") in [str(p) for p in state.recent.paths]
        assert np.array_equal(viewer.picture(), pixels(tmp_path / "a.png"))   # the picture render drew
        (tmp_path / "bad.json").write_text('{"format": "isoscope-scene", "version": 1, "volume": 3}')
        with pytest.raises(SceneError, match="bad.json: levels is missing"):
            viewer.open(str(tmp_path / "bad.json"))
        assert [level.value for level in state.levels.items] == [100.0, 170.0]   # the last good one stays
    finally:
        viewer.release()
