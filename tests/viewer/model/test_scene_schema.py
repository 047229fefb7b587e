"""One schema for scenes (viewer/model/scene_schema.py): every field typed and range-checked, unknown keys
named, open_options only the command's own flags, relative paths from the scene's folder.  Whatever a
scene file holds, reading it gives a checked scene or one SceneError line, never another exception."""
from __future__ import annotations

import copy
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.command import assert_one_line_error, isoscope_here

import isoscope
from isoscope.viewer.model.scene_file import SceneError, read_scene, volume_spec

GOOD = {
    "format": "isoscope-scene", "version": 1,
    "volume": {"source": "sphere", "open_options": {}, "gradient_direction": "ascent"},
    "levels": [{"value": 0.0, "color": None, "opacity": 1.0, "visible": True}],
    "selected": 0,
    "mesh": {"cells": "cubes", "smooth": 0, "sharp": None, "closed": False},
    "labels": False, "color_by": None,
    "camera": {"azimuth": -60.0, "elevation": 25.0, "distance": 6.3, "target": [0.0, 0.0, 0.0]},
    "size": [200, 150],
    "slices": {"shown": [False, False, False], "index": [8, 8, 8], "active": 2, "window": None, "centre": None,
               "colormap": "gray", "inset": True, "clip": None},
    "style": {"front_color": [0.5, 0.7, 0.9], "background": [0.1, 0.1, 0.1], "lighting": True},
}


def _paths(value, prefix=()):
    """Every place in the scene a value sits (dict keys and list indices), the scene itself excluded."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield (*prefix, key)
            yield from _paths(item, (*prefix, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield (*prefix, i)
            yield from _paths(item, (*prefix, i))


PATHS = list(_paths(GOOD))
JSON_VALUES = st.recursive(st.none() | st.booleans() | st.integers(-10**20, 10**20)
                           | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=12),
                           lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                                                        max_size=3), max_leaves=8)


def _read(tmp_path, scene) -> dict | None:
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scene))
    try:
        return read_scene(path)
    except SceneError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(("s.json", "the scene")), str(exc)
        assert isinstance(exc, isoscope.IsoscopeError)
        return None


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.sampled_from(PATHS), value=JSON_VALUES)
def test_any_value_in_any_field_is_read_or_refused_in_one_line(tmp_path, where, value):
    scene = copy.deepcopy(GOOD)
    parent = scene
    for key in where[:-1]:
        parent = parent[key]
    parent[where[-1]] = value
    _read(tmp_path, scene)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.text(min_size=1, max_size=10), where=st.sampled_from([(), ("camera",), ("mesh",), ("slices",),
                                                                    ("volume", "open_options")]))
def test_unknown_keys_are_named(tmp_path, key, where):
    scene = copy.deepcopy(GOOD)
    place = scene
    for step in where:
        place = place[step]
    if key in place:
        return
    place[key] = 1
    with pytest.raises(SceneError, match="unknown key"):
        read_scene(_written(tmp_path, scene))


def _written(tmp_path, scene, text=None):
    path = tmp_path / "s.json"
    path.write_text(text if text is not None else json.dumps(scene))
    return path


@pytest.mark.parametrize("change, words", [
    (lambda s: s.__setitem__("size", [0, 0]), r"size\[0\] 0 must be a whole number of pixels, 16 to 16,384"),
    (lambda s: s.__setitem__("size", [-800, 600]), "16 to 16,384"),
    (lambda s: s["camera"].__setitem__("distance", 1e308), "camera.distance"),
    (lambda s: s["slices"].__setitem__("active", 7), "slices.active 7 must be an axis, 0 to 2"),
    (lambda s: s["levels"][0].__setitem__("color", "red"), r"levels\[0\].color 'red' must be a list of 3"),
    (lambda s: s["style"].__setitem__("background", [255, 0, 0]), r"style.background\[0\] 255"),
    (lambda s: s.__setitem__("version", True), "version true"),
    (lambda s: s["mesh"].__setitem__("smooth", 10**9), "mesh.smooth .* 0 to 500"),
    (lambda s: s["volume"].__setitem__("open_options", {"map_files": True}), "unknown key 'map_files'"),
    (lambda s: s.__setitem__("camera", [1, 2]), "camera .* must be an object"),
    (lambda s: s.__setitem__("selected", 3), "selected 3 names no level"),
])
def test_the_cases_of_the_last_round(tmp_path, change, words):
    scene = copy.deepcopy(GOOD)
    change(scene)
    with pytest.raises(SceneError, match=words):
        read_scene(_written(tmp_path, scene))


def test_non_json_numbers_and_deep_nesting_are_one_line(tmp_path):
    text = json.dumps(GOOD)
    for bad, words in ((text.replace('"azimuth": -60.0', '"azimuth": NaN'), "NaN is not a JSON number"),
                       (text.replace('"selected": 0', '"selected": Infinity'), "Infinity"),
                       ('{"format": "isoscope-scene", "version": 1, "x": ' + "[" * 100_000 + "]" * 100_000 + "}",
                        "too deeply")):
        with pytest.raises(SceneError, match=words):
            read_scene(_written(tmp_path, None, bad))


def test_paths_with_control_characters_are_escaped(tmp_path):
    scene = copy.deepcopy(GOOD)
    scene["volume"]["source"] = "/tmp/\x1b]0;owned\x07\nx.nii"
    with pytest.raises(SceneError) as caught:
        read_scene(_written(tmp_path, scene))
    assert "\x1b" not in str(caught.value) and "\n" not in str(caught.value) and "\\x1b]0;owned" in str(caught.value)


def test_relative_paths_are_taken_from_the_scenes_folder(tmp_path, monkeypatch):
    import numpy as np
    folder = tmp_path / "study"
    folder.mkdir()
    np.save(folder / "ball.npy", np.zeros((4, 4, 4), np.float32))
    scene = copy.deepcopy(GOOD)
    scene["volume"]["source"] = "ball.npy"
    scene["volume"]["open_options"] = {"spacing": [1, 2, 3]}
    monkeypatch.chdir(tmp_path)   # not the scene's folder
    spec, options = volume_spec(read_scene(_written(folder, scene)))
    assert spec == str(folder / "ball.npy") and options == {"spacing": (1, 2, 3)}
    assert read_scene(_written(folder, GOOD))["volume"]["source"] == "sphere"   # a built-in stays one


@pytest.mark.gl
def test_render_takes_scene_as_a_flag(tmp_path):
    path = _written(tmp_path, GOOD)
    done = isoscope_here("render", "--scene", path, "--out", tmp_path / "a.png")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "a.png").stat().st_size > 0
    assert_one_line_error(isoscope_here("render", "sphere", "--scene", path, "--out", tmp_path / "b.png"),
                          "either, not both")
