"""isoscope movie --time on a series (issue 27): each frame is `render --time N` of the same view, several
levels, their opacities and a slice (its window given: the viewer keeps the first time point's) kept on every
time point (the movie steps the viewer's time axis)."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from support.command import isoscope_here

pytestmark = pytest.mark.gl
SIZE = ("--size", "160x120")


def test_every_time_point_of_a_movie_is_render_at_that_time_with_every_level_and_slice(tmp_path):
    axis = np.linspace(-1, 1, 24, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    distance = [np.sqrt((x - c) ** 2 + y * y + z * z) for c in (-0.3, 0.0, 0.3)]
    for t, d in enumerate(distance):
        np.save(tmp_path / f"f_{t}.npy", 0.5 - d)   # a glob series, a ball moving along x
    view = (*SIZE, "--iso", "0.2", "--iso", "0", "--opacity", "1,0.4",
            "--slice", "z=12", "--window", "1", "--level", "0")
    series = str(tmp_path / "f_*.npy")
    done = isoscope_here("movie", series, *view, "--time", "all", "--out", f"{tmp_path / 'frames'}/")
    assert done.returncode == 0, done.stderr
    frames = sorted((tmp_path / "frames").iterdir())
    assert [p.name for p in frames] == [f"frame_{t:04d}.png" for t in range(3)]
    pictures = []
    for t, frame in enumerate(frames):
        out = tmp_path / f"r{t}.png"
        done = isoscope_here("render", series, *view, "--time", str(t), "--out", out)
        assert done.returncode == 0, done.stderr
        pictures.append(np.asarray(Image.open(frame)))
        assert np.array_equal(pictures[-1], np.asarray(Image.open(out)))
    assert not np.array_equal(pictures[0], pictures[1])
