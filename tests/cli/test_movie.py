"""`isoscope movie` (issue 27): turntable, iso sweep and a series' time points, read back by imageio
(ffmpeg for the MP4, Pillow for the GIF) and compared with `render`'s PNG of the same state."""
from __future__ import annotations

import imageio.v2 as imageio
import numpy as np
import pytest
from PIL import Image
from support.command import NO_GL, assert_one_line_error, isoscope, isoscope_here

pytestmark = pytest.mark.gl
SIZE = ("--size", "160x120")


def made(*args):
    result = isoscope_here("movie", *args)
    assert result.returncode == 0, result.stderr
    return result


def test_a_turntable_mp4_has_its_frames_size_and_rate_and_starts_as_render_draws(tmp_path):
    made("torus", *SIZE, "--turntable", "8", "--fps", "10", "--azimuth", "30", "--out", tmp_path / "spin.mp4")
    reader = imageio.get_reader(tmp_path / "spin.mp4", format="FFMPEG")
    meta = reader.get_meta_data()
    frames = [reader.get_data(i) for i in range(reader.count_frames())]
    reader.close()
    assert len(frames) == 8 and meta["fps"] == 10 and frames[0].shape == (120, 160, 3)
    assert all(np.abs(a.astype(int) - b).mean() > 0.5 for a, b in zip(frames, frames[1:]))   # it turns
    stills = {}
    for azimuth in (30, 75):   # frame 0, and frame 1 an eighth of a turn on (a quarter would look the same)
        assert isoscope_here("render", "torus", *SIZE, "--azimuth", str(azimuth), "--out",
                             tmp_path / f"r{azimuth}.png").returncode == 0
        stills[azimuth] = np.asarray(Image.open(tmp_path / f"r{azimuth}.png").convert("RGB")).astype(int)

    def off(frame, azimuth):
        return np.abs(frame.astype(int) - stills[azimuth]).mean()
    assert off(frames[0], 30) < 4 and off(frames[1], 75) < 4   # H.264's error, not another picture
    assert off(frames[1], 30) > 2 * off(frames[1], 75)


def test_a_sweep_to_a_folder_is_render_at_each_level(tmp_path):
    made("gyroid", *SIZE, "--sweep=-0.5:0.5", "--frames", "3", "--out", f"{tmp_path / 'sweep'}/")
    names = sorted(p.name for p in (tmp_path / "sweep").iterdir())
    assert names == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    for name, level in zip(names, ("-0.5", "0", "0.5")):
        out = tmp_path / f"r{level}.png"
        assert isoscope_here("render", "gyroid", *SIZE, "--iso", level, "--out", out).returncode == 0
        assert np.array_equal(np.asarray(Image.open(tmp_path / "sweep" / name)), np.asarray(Image.open(out)))


def test_a_series_gif_has_a_frame_per_time_point(tmp_path):
    axis = np.linspace(-1, 1, 20, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    np.save(tmp_path / "s.npy", np.stack([r - np.sqrt(x * x + y * y + z * z) for r in (0.3, 0.5, 0.7, 0.9)]))
    made(tmp_path / "s.npy", *SIZE, "--iso", "0", "--time", "all", "--fps", "5", "--out", tmp_path / "grow.gif")
    frames = imageio.mimread(tmp_path / "grow.gif")
    assert len(frames) == 4 and frames[0].shape[:2] == (120, 160)
    lit = [int((np.asarray(f)[..., :3].astype(int).sum(axis=2) > 200).sum()) for f in frames]
    assert lit == sorted(lit) and lit[0] < lit[-1]   # the ball grows on screen
    with Image.open(tmp_path / "grow.gif") as gif:
        assert gif.info["duration"] == 200


@pytest.mark.parametrize("args, words", [
    (("--out", "m.avi"), (".mp4, .gif or a folder",)),
    (("--sweep", "0:9", "--out", "m.mp4"), ("--sweep 0:9 leaves",)),
    (("--frames", "5", "--out", "m.mp4"), ("--frames",)),
    (("--turntable", "0", "--out", "m.mp4"), ("--turntable",)),
    (("--fps", "0", "--out", "m.mp4"), ("--fps",)),
])
def test_bad_movies_are_one_line_and_leave_no_file(tmp_path, args, words):
    assert_one_line_error(isoscope_here("movie", "torus", *SIZE, *args, cwd=tmp_path), *words)
    assert not list(tmp_path.iterdir())


def test_with_no_gl_a_movie_says_it_needs_opengl_in_one_line(tmp_path):
    done = isoscope("movie", "torus", "--out", tmp_path / "m.mp4", env_add=NO_GL, env_drop=("DISPLAY",))
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 1 and len(lines) == 1 and "movie needs OpenGL 4.1" in lines[0], done.stderr
    assert not list(tmp_path.iterdir())
