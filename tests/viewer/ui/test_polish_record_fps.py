"""Record writes its movie at the frame rate in the field beside it (the movie's fps), read back by
imageio's ffmpeg reader (MP4) and Pillow (GIF: each frame's duration)."""
from __future__ import annotations

import time

import numpy as np
import pytest
from PIL import Image

from isoscope.viewer.ui.time_panel import RECORD_FPS, Recorder

pytestmark = pytest.mark.gl
SIZE = (64, 48)


def record(gl_ctx, path, fps, frames=6):
    """Record a few frames of a framebuffer cleared a new colour each time, at `fps`."""
    framebuffer = gl_ctx.simple_framebuffer(SIZE)
    recorder = Recorder()
    if fps is not None:
        recorder.set_fps(fps)
    recorder.start(path)
    try:
        for i in range(frames):
            framebuffer.use()
            framebuffer.clear(i / frames, 0.2, 0.6, 1.0)
            recorder.capture(framebuffer, SIZE)
            time.sleep(1.5 / recorder.fps)   # at least one frame's time: each shot is written (not a check)
        written = recorder.stop()
    finally:
        framebuffer.release()
    assert written == path, recorder.message
    return recorder


def test_an_mp4_has_the_fields_frame_rate(gl_ctx, tmp_path):
    import imageio.v2 as imageio
    recorder = record(gl_ctx, tmp_path / "slow.mp4", 12)
    assert "at 12 fps" in recorder.message
    reader = imageio.get_reader(tmp_path / "slow.mp4", format="FFMPEG")
    try:
        assert reader.get_meta_data()["fps"] == pytest.approx(12, abs=0.01)
        assert reader.count_frames() == recorder.frames >= 6
    finally:
        reader.close()
    record(gl_ctx, tmp_path / "default.mp4", None)
    reader = imageio.get_reader(tmp_path / "default.mp4", format="FFMPEG")
    try:
        assert reader.get_meta_data()["fps"] == pytest.approx(RECORD_FPS, abs=0.01)
    finally:
        reader.close()


def test_a_gif_frames_last_one_over_the_rate(gl_ctx, tmp_path):
    record(gl_ctx, tmp_path / "clip.gif", 10)
    with Image.open(tmp_path / "clip.gif") as gif:
        assert gif.n_frames >= 2
        gif.seek(1)
        assert gif.info["duration"] == pytest.approx(100, abs=10)   # ms: 1 / 10 fps


@pytest.mark.parametrize("bad", [0, 0.5, 241, float("nan")])
def test_a_rate_out_of_bounds_is_one_line_and_keeps_the_last(bad):
    recorder = Recorder()
    recorder.set_fps(15)
    with pytest.raises(ValueError, match=r"^record at .* fps: give 1 to 240 frames per second$"):
        recorder.set_fps(bad)
    assert recorder.fps == 15


def test_the_field_sits_beside_record_in_the_panel(gl_ctx, tmp_path):
    from isoscope.viewer.ui.headless import HeadlessViewer
    from isoscope.volumes import open_volume
    viewer = HeadlessViewer((900, 1100), ctx=gl_ctx)
    try:
        viewer.show(open_volume("sphere"))
        plain = viewer.render(panel=True)
        viewer._panel.time_section.recorder.set_fps(7)
        changed = viewer.render(panel=True)
    finally:
        viewer.release()
    differ = np.argwhere((plain != changed).any(axis=2))
    assert len(differ) > 0   # the field shows the rate: "30 fps" -> "7 fps", only there
    rows, cols = differ[:, 0], differ[:, 1]
    assert rows.max() - rows.min() < 30 and cols.max() - cols.min() < 80
    Image.fromarray(changed).save(tmp_path / "panel.png")
