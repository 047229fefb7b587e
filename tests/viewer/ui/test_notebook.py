"""isoscope.widget (issue 25): made without a browser, its canvas shows the surface, the slider moves the
level, a simulated pointer drag orbits, the wheel zooms."""
from __future__ import annotations

import numpy as np
import pytest

import isoscope

pytestmark = pytest.mark.gl
pytest.importorskip("jupyter_rfb")


def lit(frame: np.ndarray) -> int:
    """Pixels brighter than the background: the surface's area on screen."""
    return int((frame.astype(int).sum(axis=2) > 250).sum())


def test_the_widget_draws_moves_its_level_and_orbits():
    axis = np.linspace(-1, 1, 32, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    box = isoscope.widget(0.7 - np.sqrt(x * x + y * y + z * z), 0.0, size=(160, 120))
    try:
        first = box.canvas.get_frame()
        assert first.shape == (120, 160, 3) and first.dtype == np.uint8 and lit(first) > 500
        box.slider.value = 0.4                                  # a smaller ball
        smaller = box.canvas.get_frame()
        assert 0 < lit(smaller) < lit(first) * 0.6
        azimuth = box.viewer.camera.azimuth
        for event in ({"type": "pointer_down", "x": 80, "y": 60, "button": 1, "modifiers": []},
                      {"type": "pointer_move", "x": 130, "y": 60, "buttons": [1], "modifiers": []},
                      {"type": "pointer_up", "x": 130, "y": 60, "button": 1, "modifiers": []}):
            box.canvas.handle_event(event)
        assert box.viewer.camera.azimuth != azimuth
        assert not np.array_equal(box.canvas.get_frame(), smaller)   # the box turned with it
        box.canvas.handle_event({"type": "wheel", "x": 80, "y": 60, "dx": 0, "dy": -300, "modifiers": []})
        assert lit(box.canvas.get_frame()) > lit(smaller)         # zoomed in
    finally:
        box.close_viewer()


def test_the_widget_shows_the_volume_itself_as_render_does():
    axis = np.linspace(-1, 1, 32, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    field = np.exp(-4 * (x * x + y * y + z * z)).astype(np.float32)
    box = isoscope.widget(field, 0.5, size=(160, 120), raycast="mip")
    try:
        frame = box.canvas.get_frame()
        assert np.array_equal(frame, isoscope.render(field, 0.5, size=(160, 120), raycast="mip")[..., :3])
        assert box.viewer.state.raycast == "mip"
    finally:
        box.close_viewer()


def test_the_widget_draws_the_surfaces_with_the_rays_as_render_does():
    """with_surfaces=True: the level-0.5 surface ends the rays, the same picture as isoscope.render's, and
    not the picture without it."""
    axis = np.linspace(-1, 1, 32, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    field = np.exp(-4 * (x * x + y * y + z * z)).astype(np.float32)
    box = isoscope.widget(field, 0.5, size=(160, 120), raycast="mip", with_surfaces=True)
    try:
        frame = box.canvas.get_frame()
        options = dict(size=(160, 120), raycast="mip")
        assert np.array_equal(frame, isoscope.render(field, 0.5, with_surfaces=True, **options)[..., :3])
        assert np.abs(frame.astype(int) - isoscope.render(field, 0.5, **options)[..., :3]).max() > 50
    finally:
        box.close_viewer()
