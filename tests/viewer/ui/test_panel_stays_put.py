"""The panel stays put (issue 26, points 3-5): a message or a refused change moves no control, the panel
fits the window (and scrolls inside it), values stand beside the sliders, tooltips beside the panel.

Headless, as a render with --panel draws it: the panel records where its controls are (section headers,
the iso slider, the histogram, the slice checkboxes, the sharp features checkbox), and the pixels of its
box are compared before and after.
"""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.viewer.model.formats import level_text
from isoscope.viewer.model.settings import PanelSettings
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.viewer.ui.mesh_panel import MESH_TITLE
from isoscope.viewer.ui.panel import PANEL_TITLE, Panel
from isoscope.volumes import open_volume

OUTSIDE = (1200.0, 700.0)   # a place for the pointer away from the panel (no hover highlight)
ERROR_RGB = (255, 115, 102)   # panel.ERROR_COLOR
NOTE_RGB = (153, 217, 153)    # panel.NOTE_COLOR
HINT_RGB = (242, 191, 89)     # panel.HINT_COLOR


@pytest.fixture
def viewer(gl_ctx):
    viewer = HeadlessViewer((1280, 800), ctx=gl_ctx)
    viewer.show(open_volume("sphere", resolution=32), iso=0.0)
    yield viewer
    viewer.release()


def frame(viewer, frames: int = 2) -> np.ndarray:
    """A few frames with the panel (imgui settles a new window's size in its second); the last picture."""
    for _ in range(frames):
        image = viewer.render(panel=True)
    return image


def settled(viewer) -> np.ndarray:
    """The panel laid out, the pointer away from it, and the picture once it shows no hover."""
    frame(viewer)
    move_pointer(*OUTSIDE)
    return frame(viewer)


def layout(viewer) -> dict:
    """Where the panel's controls are: every recorded rect, by name."""
    panel = viewer._panel
    rects = {f"header {title}": box for title, box in panel.section_boxes.items()}
    rects.update({f"slice checkbox {axis}": box for axis, box in panel.slices.checkbox_boxes.items()})
    rects.update({"iso slider": panel.iso_slider_box, "histogram": panel.histogram_box, "panel": panel.box,
                  "sharp features": panel.mesh_section.sharp_box})
    return rects


def panel_pixels(viewer, image) -> np.ndarray:
    x, y, width, height = (int(round(v)) for v in viewer._panel.box)
    return image[y:y + height, x:x + width]


def coloured(image, rgb, tolerance: int = 12) -> int:
    return int((np.abs(image.astype(int) - rgb) <= tolerance).all(axis=2).sum())


def box_pixels(image, box) -> np.ndarray:
    x, y, width, height = (int(round(v)) for v in box)
    return image[y:y + height, x:x + width]


def move_pointer(x, y) -> None:
    from imgui_bundle import imgui
    imgui.get_io().add_mouse_pos_event(float(x), float(y))


def click(viewer, point) -> None:
    """A press and release at `point`, a frame each, as imgui's GLFW backend feeds them."""
    from imgui_bundle import imgui
    io = imgui.get_io()
    io.add_mouse_pos_event(*map(float, point))
    viewer.render(panel=True)
    io.add_mouse_button_event(0, True)
    viewer.render(panel=True)
    io.add_mouse_button_event(0, False)
    viewer.render(panel=True)


def centre(box) -> tuple[float, float]:
    (left, top), (right, bottom) = box
    return (left + right) / 2, (top + bottom) / 2


def test_a_message_moves_no_control(viewer):
    before_image = settled(viewer)
    before = layout(viewer)
    assert viewer._panel.status_box is None
    viewer.state.message = "screenshot saved: /tmp/isoscope-0001.png"
    after_image = frame(viewer)
    assert layout(viewer) == before
    assert np.array_equal(panel_pixels(viewer, after_image), panel_pixels(viewer, before_image))
    # The message is in the status line, at the window's bottom, under the panel.
    x, y, width, height = viewer._panel.status_box
    assert y >= sum(before["panel"][1::2]) and y + height <= 800
    assert coloured(box_pixels(after_image, viewer._panel.status_box), NOTE_RGB) > 100
    # An error too, and back: still nothing moves.
    viewer.state.error = "could not open broken.npy: not a numpy file; check the path"
    error_image = frame(viewer)
    assert layout(viewer) == before
    assert np.array_equal(panel_pixels(viewer, error_image), panel_pixels(viewer, before_image))
    assert coloured(box_pixels(error_image, viewer._panel.status_box), ERROR_RGB) > 100


def test_a_refusal_shows_beside_its_control_and_moves_nothing(viewer):
    state = viewer.state
    viewer._panel.settings.set_open(MESH_TITLE, True)
    state.set_cells("tetrahedra")
    before_image = settled(viewer)
    before = layout(viewer)
    sharp = before["sharp features"]
    assert sharp is not None, "the Mesh section did not open"

    click(viewer, centre(sharp))   # sharp features with tetrahedra: refused
    assert state.mesh_options.sharp is None and "tetrahedra" in state.error
    move_pointer(*OUTSIDE)
    after_image = frame(viewer)
    assert layout(viewer) == before
    assert np.array_equal(panel_pixels(viewer, after_image), panel_pixels(viewer, before_image))
    # Its reason beside the checkbox, right of the panel at its row; not in the status line.
    x, y, width, height = viewer._panel.refusal_box
    panel_x, _, panel_width, _ = before["panel"]
    assert x >= panel_x + panel_width
    assert abs(y - sharp[0][1]) <= sharp[1][1] - sharp[0][1]
    assert coloured(box_pixels(after_image, viewer._panel.refusal_box), ERROR_RGB) > 100
    assert viewer._panel.status(state, viewer.scene) is None
    # The next change that goes through takes the note away.
    click(viewer, centre(sharp))
    state.set_cells("cubes")
    click(viewer, centre(sharp))
    assert state.mesh_options.sharp is not None and state.error is None
    frame(viewer)
    assert viewer._panel.refusal_box is None


def scroll_max(viewer) -> float:
    from imgui_bundle import imgui
    return imgui.internal.find_window_by_name(PANEL_TITLE).scroll_max.y


def test_the_panel_fits_a_short_window_and_grows_with_a_tall_one(gl_ctx):
    heights = {}
    for height in (480, 1200):
        viewer = HeadlessViewer((1280, height), ctx=gl_ctx)
        try:
            viewer.show(open_volume("sphere", resolution=32), iso=0.0)
            frame(viewer)
            x, y, width, panel_height = viewer._panel.box
            # Its bottom stays above the status line's place, whatever the content's height.
            assert y + panel_height <= height - Panel.status_height() - 8
            heights[height] = (panel_height, scroll_max(viewer))
        finally:
            viewer.release()
    (short, short_scroll), (tall, tall_scroll) = heights[480], heights[1200]
    assert short_scroll > 0, "the short window's panel does not scroll"
    assert tall > short + 300 and tall_scroll < short_scroll


def test_values_stand_beside_their_sliders_in_one_format(viewer):
    state = viewer.state
    state.levels.set_value(0.1234)
    frame(viewer)
    (left, top), (right, bottom) = viewer._panel.iso_slider_box
    panel_x, _, panel_width, _ = viewer._panel.box
    # The typed value sits right of the slider, as the Surfaces row writes it.
    assert right < panel_x + panel_width - 60
    assert level_text(state.iso, state.value_range) == "0.123"


def test_a_tooltip_stands_beside_the_panel(viewer):
    from imgui_bundle import imgui
    frame(viewer)
    point = centre(viewer._panel.histogram_box)
    move_pointer(*point)
    for _ in range(40):   # imgui's hover delay (0.15 s) at 1/60 s a frame
        viewer.render(panel=True)
    tooltip = imgui.internal.find_window_by_name("##Tooltip_00")
    assert tooltip is not None and tooltip.active, "no tooltip over the histogram"
    panel_x, _, panel_width, _ = viewer._panel.box
    assert tooltip.pos.x >= panel_x + panel_width, "the tooltip covers the panel"


def test_an_empty_level_says_where_the_values_are(gl_ctx):
    viewer = HeadlessViewer((1280, 800), ctx=gl_ctx)
    try:
        viewer.show(open_volume("bucky"))
        state = viewer.state
        low, high = state.value_range
        state.levels.set_value(low)   # every voxel inside (ties count as inside): no surface
        image = frame(viewer, 3)
        assert viewer.scene.stats.n_triangles == 0
        text, _ = viewer._panel.status(state, viewer.scene)
        assert text.startswith(f"no surface at {level_text(low, (low, high))}: the values lie in ")
        assert "most between" in text
        assert coloured(box_pixels(image, viewer._panel.status_box), HINT_RGB) > 100
        assert viewer._panel.levels_section.flags == {0: "empty"}
        state.set_raycast("mip")   # the volume ray cast alone: no surface is drawn, so none is said empty
        frame(viewer, 3)
        assert viewer._panel.status(state, viewer.scene) is None and viewer._panel.levels_section.flags == {}
        state.set_with_surfaces(True)
        frame(viewer, 3)
        assert viewer._panel.status(state, viewer.scene)[0] == text
        state.set_raycast(None)
        state.levels.set_value((low + high) / 2)
        frame(viewer, 3)
        assert viewer.scene.stats.n_triangles > 0 and viewer._panel.status(state, viewer.scene) is None
        assert viewer._panel.levels_section.flags == {}
    finally:
        viewer.release()


def test_a_surface_inside_an_opaque_one_is_flagged(viewer):
    state = viewer.state   # a signed distance: the object is below the level, a lower level lies inside
    state.levels.add(-0.2)
    frame(viewer)
    assert viewer._panel.levels_section.flags == {1: "hidden"}
    text, _ = viewer._panel.status(state, viewer.scene)   # the selected level: said in the status line too
    assert text.startswith("surface 2 (-0.200) lies inside surface 1, which is opaque")
    viewer._panel.settings.set_open("Surfaces", False)    # and while its row is folded away
    frame(viewer)
    assert viewer._panel.status(state, viewer.scene)[0] == text
    viewer._panel.settings.set_open("Surfaces", True)
    state.levels.set_opacity(0, 0.5)
    frame(viewer)
    assert viewer._panel.levels_section.flags == {}
    state.levels.set_opacity(0, 1.0)
    state.slices.set_clip(2)   # a clip plane opens the outer one
    frame(viewer)
    assert viewer._panel.levels_section.flags == {}


def test_folded_sections_are_remembered_in_a_settings_file(gl_ctx, tmp_path):
    import json
    path = tmp_path / "panel.json"
    viewer = HeadlessViewer((1280, 800), ctx=gl_ctx)
    try:
        viewer._panel = Panel(can_browse=False, settings=PanelSettings(path))
        viewer.show(open_volume("sphere", resolution=32), iso=0.0)
        frame(viewer)
        assert viewer._panel.slices.checkbox_boxes
        click(viewer, centre(viewer._panel.section_boxes["Slices"]))
        frame(viewer)
        assert not viewer._panel.slices.checkbox_boxes, "the Slices header did not fold"
    finally:
        viewer.release()
    assert json.loads(path.read_text()) == {"version": 1, "sections": {"Slices": False}}

    again = HeadlessViewer((1280, 800), ctx=gl_ctx)   # the next run
    try:
        again._panel = Panel(can_browse=False, settings=PanelSettings(path))
        again.show(open_volume("sphere", resolution=32), iso=0.0)
        frame(again)
        assert "Slices" in again._panel.section_boxes and not again._panel.slices.checkbox_boxes
        assert again._panel.iso_slider_box is not None   # the others as they were
    finally:
        again.release()


def test_a_refusal_from_a_combo_shows_beside_the_combo(viewer):
    from imgui_bundle import imgui
    state = viewer.state
    viewer._panel.settings.set_open(MESH_TITLE, True)
    state.set_sharp(30.0)
    settled(viewer)
    (left, _), (_, header_bottom) = viewer._panel.section_boxes[MESH_TITLE]
    row = header_bottom + imgui.get_style().item_spacing.y + imgui.get_frame_height() / 2   # "cells"
    click(viewer, (left + 60, row))
    frame(viewer)
    popup = imgui.internal.find_window_by_name("##Combo_00")
    assert popup is not None and popup.active, "the cells combo did not open"
    click(viewer, (popup.pos.x + 30, popup.pos.y + popup.size.y * 0.75))   # its second choice: tetrahedra
    move_pointer(*OUTSIDE)
    frame(viewer)
    assert state.mesh_options.cells == "cubes" and "tetrahedra" in state.error
    x, y, width, height = viewer._panel.refusal_box
    assert x >= sum(viewer._panel.box[0::2]) and abs(y - (row - imgui.get_frame_height() / 2)) <= 4


def test_a_refusal_goes_to_the_status_line_while_the_panel_is_folded(viewer):
    from imgui_bundle import imgui
    viewer._panel.settings.set_open(MESH_TITLE, True)
    viewer.state.set_cells("tetrahedra")
    settled(viewer)
    click(viewer, centre(viewer._panel.mesh_section.sharp_box))
    frame(viewer)
    assert viewer._panel.refusal_box is not None
    imgui.set_window_collapsed(PANEL_TITLE, True)   # the title bar's arrow
    frame(viewer)
    assert viewer._panel.box is None and viewer._panel.refusal_box is None
    assert "tetrahedra" in viewer._panel.status(viewer.state, viewer.scene)[0]
