"""The panel at 4K (issue 26, point 8): `isoscope render --size 3840x2160 --panel` draws the panel as a 4K
monitor's content scale would, twice the 1080p one, read off the pictures' pixels (the title bar's colour)."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from support.command import isoscope_here

pytestmark = pytest.mark.gl
TITLE_RGB = (41, 74, 122)   # imgui's dark style's active title bar (0.16, 0.29, 0.48)


def title_bar(path) -> tuple[int, int]:
    """(width, height) in pixels of the panel's title bar: the rows near the top that are mostly its colour."""
    image = np.asarray(Image.open(path).convert("RGB")).astype(int)
    bar = (np.abs(image[:200] - TITLE_RGB) <= 4).all(axis=2)
    rows = np.nonzero(bar.sum(axis=1) > 100)[0]
    assert len(rows), f"no title bar in {path}"
    cols = np.nonzero(bar[rows].any(axis=0))[0]
    return int(cols.max() - cols.min() + 1), int(rows.max() - rows.min() + 1)


def test_a_4k_render_draws_the_panel_twice_the_1080p_size(tmp_path):
    sizes = {}
    for size in ("1920x1080", "3840x2160"):
        out = tmp_path / f"{size}.png"
        result = isoscope_here("render", "bucky", "--panel", "--size", size, "--out", out)
        assert result.returncode == 0, result.stderr
        sizes[size] = title_bar(out)
    (width, height), (width_4k, height_4k) = sizes["1920x1080"], sizes["3840x2160"]
    assert 300 <= width <= 360 and 14 <= height <= 24   # 1x, as before
    assert width_4k == pytest.approx(2 * width, rel=0.05)
    assert height_4k == pytest.approx(2 * height, rel=0.1)


def test_the_panel_scales_again_on_another_monitor(gl_ctx):
    """A window moved to a monitor of another content scale: the panel's sizes follow, and come back."""
    from imgui_bundle import imgui

    from isoscope.viewer.ui.panel import ImguiLayer
    layer = ImguiLayer()
    try:
        padding = tuple(imgui.get_style().frame_padding)
        layer.set_scale(2.0)
        assert tuple(imgui.get_style().frame_padding) == (2 * padding[0], 2 * padding[1])
        assert imgui.get_style().font_scale_dpi == 2.0
        layer.set_scale(1.0)
        assert tuple(imgui.get_style().frame_padding) == padding and imgui.get_style().font_scale_dpi == 1.0
    finally:
        layer.shutdown()
