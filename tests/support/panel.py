"""The panel's histogram in headless renders: where its level markers are drawn, and a click on it through imgui."""
from __future__ import annotations

import numpy as np


def marker_columns(image, box, colour):
    """Columns inside the histogram's box drawn in the level marker's colour."""
    (left, top), (right, bottom) = (tuple(int(round(v)) for v in corner) for corner in box)
    region = image[top:bottom, left:right].astype(int)
    hits = (np.abs(region - np.round(255 * np.array(colour))) <= 3).all(axis=2).sum(axis=0)
    return left + np.nonzero(hits > (bottom - top) // 2)[0]


def assert_marker_at(image, box, colour, level, value_range):
    """The histogram shows a marker in `colour` where `level` falls in `value_range`."""
    from isoscope.viewer.model.histogram import fraction_of
    (left, _), (right, _) = box
    columns = marker_columns(image, box, colour)
    expected = left + fraction_of(level, value_range) * (right - left)
    assert len(columns) and abs(columns.mean() - expected) <= 2, (level, columns)


def click_histogram(viewer, fraction):
    """A press and release on the panel's histogram, `fraction` of the way across, over three frames."""
    from imgui_bundle import imgui
    (left, top), (right, bottom) = viewer._panel.histogram_box
    io = imgui.get_io()
    io.add_mouse_pos_event(left + fraction * (right - left), (top + bottom) / 2)
    for down in (True, True, False):
        io.add_mouse_button_event(0, down)
        viewer.render(panel=True)
