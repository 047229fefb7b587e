"""Anatomical orientation letters (R/L, A/P, S/I) at the edges of the 3-D view.

A scan with a voxel-to-world transform (NIfTI, NRRD, DICOM: `Volume.world`) says which way
its array axes point in the patient; the viewer's scene is array index x spacing, so a scene
direction v is the world direction ``A @ (v / spacing)`` (A: the transform's 3x3 part).  Each
edge of the view is labelled with the anatomical direction that the screen's right and up
vectors point to, as 3D Slicer and ITK-SNAP label their views: one letter when the direction is
close to an axis, two (dominant first) when it is oblique.  Volumes without a transform (npy,
raw, built-ins) get no letters: their axes mean nothing anatomical.
"""
from __future__ import annotations

import numpy as np

from .gui import imgui

# The letter for the positive and the negative end of each world axis, per convention.
_AXIS_LETTERS = {
    "RAS": (("R", "L"), ("A", "P"), ("S", "I")),
    "LPS": (("L", "R"), ("P", "A"), ("S", "I")),
}
SECOND_LETTER_FRACTION = 0.5   # an axis whose share is at least this much of the dominant one is named too
LABEL_MARGIN = 10.0            # pixels between a letter and the view's edge
LABEL_COLOR = 0xE6E6E6E6       # ABGR: light grey, readable on the dark background


def direction_letters(world_direction, space: str) -> str:
    """'R', 'A', 'S' ... or two letters such as 'RA' for a world direction in `space` (RAS or LPS)."""
    direction = np.asarray(world_direction, float)
    letters = _AXIS_LETTERS[space]
    order = np.argsort(-np.abs(direction))
    dominant = abs(direction[order[0]])
    if dominant == 0:
        return ""
    chosen = [axis for axis in order[:2] if abs(direction[axis]) >= SECOND_LETTER_FRACTION * dominant]
    return "".join(letters[axis][0 if direction[axis] > 0 else 1] for axis in chosen)


def screen_letters(world: tuple[np.ndarray, str] | None, spacing, right, up) -> dict[str, str] | None:
    """Letters for the view's right, left, top and bottom edges, given the camera's right and up
    vectors in scene space; None when the volume has no world transform."""
    if world is None:
        return None
    matrix, space = world
    to_world = np.asarray(matrix, float)[:3, :3] / np.asarray(spacing, float)   # A @ diag(1/spacing)
    right_world, up_world = to_world @ np.asarray(right, float), to_world @ np.asarray(up, float)
    return {"right": direction_letters(right_world, space), "left": direction_letters(-right_world, space),
            "top": direction_letters(up_world, space), "bottom": direction_letters(-up_world, space)}


def draw_screen_letters(letters: dict[str, str] | None, view: tuple[float, float, float, float]) -> None:
    """Draw `letters` at the middle of each edge of `view` (x, y, width, height in imgui units),
    on imgui's background layer: under the panel, over the scene."""
    if not letters:
        return
    x, y, width, height = view
    draw_list = imgui.get_background_draw_list()
    for edge, text in letters.items():
        size = imgui.calc_text_size(text)
        centre_x, centre_y = x + (width - size.x) / 2, y + (height - size.y) / 2
        position = {"right": (x + width - LABEL_MARGIN - size.x, centre_y), "left": (x + LABEL_MARGIN, centre_y),
                    "top": (centre_x, y + LABEL_MARGIN), "bottom": (centre_x, y + height - LABEL_MARGIN - size.y)}
        draw_list.add_text(imgui.ImVec2(*position[edge]), LABEL_COLOR, text)


def draw_orientation(volume, camera, view: tuple[float, float, float, float]) -> None:
    """The letters for `volume` (or none) seen through `camera`, drawn around `view`."""
    if volume is not None:
        draw_screen_letters(screen_letters(volume.world, volume.spacing, *camera.screen_axes()), view)
