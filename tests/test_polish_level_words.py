"""isosurface says a level outside the volume's range in the command line's words, as view/render/widget do;
marching_cubes (scikit-image's door) keeps its own."""
from __future__ import annotations

import numpy as np
import pytest
from support.command import isoscope_here as run

import isoscope
from isoscope.validation import named_level
from isoscope.viewer.scripting import checked_levels
from isoscope.volumes import VolumeError
from isoscope.volumes.inputs import as_volume


def ball() -> np.ndarray:
    x, y, z = np.mgrid[-1:1:16j, -1:1:16j, -1:1:16j]
    return (0.6 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


def test_isosurface_says_a_level_outside_the_range_as_the_command_does(tmp_path):
    np.save(tmp_path / "ball.npy", ball())
    command = run("export", tmp_path / "ball.npy", "--iso", "5", "--out", tmp_path / "never.stl")
    assert command.returncode == 2
    with pytest.raises(VolumeError) as raised:
        isoscope.isosurface(tmp_path / "ball.npy", 5.0, backend="cpu")
    said = str(raised.value)
    assert said.startswith("level 5 is outside ball.npy's value range") and "pick a value inside it" in said
    assert command.stderr.strip().endswith(said.replace("level 5", "--iso 5"))
    with pytest.raises(VolumeError) as scripted:   # the same words as isoscope.render / view / widget
        checked_levels(as_volume(tmp_path / "ball.npy"), 5.0)
    assert str(scripted.value) == said
    with pytest.raises(VolumeError, match="not a number"):
        isoscope.isosurface(ball(), "high", backend="cpu")
    assert not (tmp_path / "never.stl").exists()


def test_a_level_inside_the_range_and_marching_cubes_words():
    assert isoscope.isosurface(ball(), 0.1, backend="cpu").is_watertight
    assert named_level(np.float32(0.25), (0.0, 1.0), "x") == 0.25
    with pytest.raises(ValueError, match=r"outside x's value range 0 \.\. 1;"):
        named_level(float("nan"), (0.0, 1.0), "x")
    with pytest.raises(ValueError, match="outside the data range"):
        isoscope.marching_cubes(ball(), 5.0)
