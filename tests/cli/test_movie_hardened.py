"""Movies stream (issue 35): frames go to ffmpeg as they are drawn (a GIF too: memory flat in the frame
count), a time point that cannot be drawn stops the movie in one line (exit 2, no file), SIGTERM leaves no
partial file and ends the process by the signal, messages name the user's path, --orientation-letters."""
from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import time
import tracemalloc

import imageio.v2 as imageio
import numpy as np
import pytest
from support.command import assert_one_line_error, isoscope_here

from isoscope.io.movie import write_movie

pytestmark = pytest.mark.gl
SIZE = ("--size", "160x120")


def _frames(count, size=(256, 256)):
    for i in range(count):
        frame = np.zeros((*size, 3), np.uint8)
        frame[:, : (i * 7) % size[1]] = (200, 40, 40)
        yield frame


def test_a_gif_is_not_held_in_memory(tmp_path):
    """Python's allocations while writing a GIF do not grow with its frames: 150 frames of 256x256 peak no
    higher than 15 frames do, within a frame (Pillow's GIF writer kept every frame: 1.7 GB for 300 frames
    of 1024x1024)."""
    write_movie(_frames(2), tmp_path / "warm.gif", 24)   # imports and first-use caches
    peaks = []
    for count in (15, 150):
        tracemalloc.start()
        try:
            write_movie(_frames(count), tmp_path / f"m{count}.gif", 24)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
    assert peaks[1] < peaks[0] + 256 * 256 * 3, peaks
    frames = imageio.mimread(tmp_path / "m150.gif")
    assert len(frames) == 150
    assert np.array_equal(np.asarray(frames[5])[..., :3][0, 0], [200, 40, 40])   # palette per frame: exact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m15.gif", "m150.gif", "warm.gif"]


def test_a_failed_write_names_the_users_path_and_leaves_nothing(tmp_path):
    """ffmpeg killed half-way (as by the OOM killer or a full disk): one OSError about the user's path."""
    def children():   # this process's ffmpeg, and nothing else of its children (multiprocessing's tracker)
        pids = [int(pid) for tasks in glob.glob(f"/proc/{os.getpid()}/task/*/children")
                for pid in open(tasks).read().split()]
        return [pid for pid in pids if "ffmpeg" in open(f"/proc/{pid}/cmdline", "rb").read().decode(errors="replace")]

    def frames():
        for i, frame in enumerate(_frames(20, (64, 64))):
            if i == 2:
                for pid in children():
                    os.kill(pid, signal.SIGKILL)
            yield frame
    out = tmp_path / "m.mp4"
    with pytest.raises(OSError) as caught:
        write_movie(frames(), out, 24)
    assert caught.value.filename == str(out) and "ffmpeg" in str(caught.value)
    assert ".partial" not in str(caught.value) and "COMMAND" not in str(caught.value)
    assert not list(tmp_path.iterdir())


def test_a_time_point_that_cannot_be_drawn_stops_the_movie(tmp_path):
    axis = np.linspace(-1, 1, 16, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    for t in range(3):
        np.save(tmp_path / f"f_{t}.npy", 0.5 - np.sqrt(x * x + y * y + z * z) + 0.1 * t)
    (tmp_path / "f_1.npy").write_bytes(b"\x93NUMPY damaged")   # unreadable in the middle
    out = tmp_path / "out" / "m.gif"
    out.parent.mkdir()
    done = isoscope_here("movie", str(tmp_path / "f_*.npy"), *SIZE, "--iso", "0", "--time", "all", "--out", out)
    assert_one_line_error(done, "time point 1", "the movie stops there")
    assert not list(out.parent.iterdir())


def test_other_shaped_time_point_stops_the_movie(tmp_path):
    for t, shape in enumerate(((12, 12, 12), (12, 12, 12), (10, 12, 12))):
        np.save(tmp_path / f"f_{t}.npy", np.random.default_rng(t).random(shape, dtype=np.float32))
    out = tmp_path / "m.mp4"
    done = isoscope_here("movie", str(tmp_path / "f_*.npy"), *SIZE, "--iso", "0.5", "--time", "all", "--out", out)
    assert done.returncode == 2 and not out.exists(), done.stderr


def test_sigterm_during_a_movie_leaves_no_partial_file(tmp_path):
    out = tmp_path / "turn.mp4"
    process = subprocess.Popen([sys.executable, "-m", "isoscope", "movie", "torus", "--size", "320x240",
                                "--turntable", "2000", "--out", str(out)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, preexec_fn=lambda: signal.signal(
                                   signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and not any(p.name.endswith(".partial.mp4") for p in tmp_path.iterdir()):
        time.sleep(0.1)
    time.sleep(1.0)   # frames being written
    assert process.poll() is None, process.stderr.read()
    process.send_signal(signal.SIGTERM)
    process.communicate(timeout=60)
    assert process.returncode == -signal.SIGTERM
    assert not list(tmp_path.iterdir())


def test_movie_draws_orientation_letters_as_render_does(tmp_path):
    volume = tmp_path / "scan.nii.gz"
    import nibabel as nib
    axis = np.linspace(-1, 1, 16, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    nib.save(nib.Nifti1Image(0.6 - np.sqrt(x * x + y * y + z * z), np.diag([2.0, 2.0, 2.0, 1.0])), volume)
    for letters, folder in (((), "plain"), (("--orientation-letters",), "letters")):
        done = isoscope_here("movie", volume, *SIZE, "--iso", "0", "--turntable", "2", *letters,
                             "--out", f"{tmp_path / folder}/")
        assert done.returncode == 0, done.stderr
    rendered = isoscope_here("render", volume, *SIZE, "--iso", "0", "--orientation-letters", "--out",
                             tmp_path / "r.png")
    assert rendered.returncode == 0, rendered.stderr
    plain, lettered = (imageio.imread(tmp_path / f / "frame_0000.png") for f in ("plain", "letters"))
    assert not np.array_equal(plain, lettered)
    assert np.array_equal(lettered, imageio.imread(tmp_path / "r.png"))


@pytest.mark.parametrize("args, words", [
    (("--smooth", "1000000000"), ("--smooth", "0 to 500")),
    (("--turntable", "100000"), ("--turntable", "1 to 10,000")),
    (("--fps", "nan"), ("--fps",)),
    (("--size", "0x0"), ("--size",)),
])
def test_numbers_are_refused_before_any_work(tmp_path, args, words):
    assert_one_line_error(isoscope_here("movie", "torus", *args, "--out", tmp_path / "m.mp4"), *words)
    assert not list(tmp_path.iterdir())
