"""Anatomical orientation letters (R/L, A/P, S/I) at the edges of the 3-D view.

A scan with a voxel-to-world transform (NIfTI, NRRD, DICOM: `Volume.world`) says which way
its array axes point in the patient; the viewer's scene is array index x spacing, so a scene
direction v is the world direction ``A @ (v / spacing)`` (A: the transform's 3x3 part).  Each
edge of the view is labelled with the anatomical direction that the screen's right and up
vectors point to, as 3D Slicer and ITK-SNAP label their views: one letter when the direction is
close to an axis, two (dominant first) when it is oblique.  The 2-D view of a slice (bottom right,
gfx/slices.py) gets its own letters, inside its frame: its right is the slice's first remaining array
axis, its top the second.  Volumes without a transform (npy, raw, built-ins) get no letters: their
axes mean nothing anatomical.
"""
from __future__ import annotations

import numpy as np

from ..gfx.slices import inset_box
from .gui import imgui

# The letter for the positive and the negative end of each world axis, per convention.
_AXIS_LETTERS = {
    "RAS": (("R", "L"), ("A", "P"), ("S", "I")),
    "LPS": (("L", "R"), ("P", "A"), ("S", "I")),
}
SECOND_LETTER_FRACTION = 0.5   # an axis whose share is at least this much of the dominant one is named too
LABEL_MARGIN = 10.0            # pixels between a letter and the view's edge
LABEL_COLOR = 0xE6E6E6E6       # ABGR: light grey, readable on the dark background
INSET_LABEL_MARGIN = 4.0       # pixels between a letter and the 2-D view's frame, inside it
SHADOW_COLOR = 0xFF000000      # a dark outline: the 2-D view's letters sit on the slice's own grey values


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
    if world is None or world[1] not in _AXIS_LETTERS:   # no patient frame (an OME-Zarr image's world)
        return None
    matrix, space = world
    to_world = np.asarray(matrix, float)[:3, :3] / np.asarray(spacing, float)   # A @ diag(1/spacing)
    right_world, up_world = to_world @ np.asarray(right, float), to_world @ np.asarray(up, float)
    return {"right": direction_letters(right_world, space), "left": direction_letters(-right_world, space),
            "top": direction_letters(up_world, space), "bottom": direction_letters(-up_world, space)}


def inset_letters(world, spacing, axis: int) -> dict[str, str] | None:
    """Letters for the edges of the 2-D view of a slice across array `axis`: its rows run right along
    the lower remaining axis, its columns up along the higher (gfx/slices.py `plane_corners`)."""
    rows_axis, columns_axis = (a for a in range(3) if a != axis)
    return screen_letters(world, spacing, np.eye(3)[rows_axis], np.eye(3)[columns_axis])


def draw_screen_letters(letters: dict[str, str] | None, view: tuple[float, float, float, float],
                        margin: float = LABEL_MARGIN, shadow: bool = False, avoid=None) -> None:
    """Draw `letters` at the middle of each edge of `view` (x, y, width, height in imgui units),
    on imgui's background layer: under the panel, over the scene; `shadow`: outlined in black.  `avoid`:
    a box (x, y, width, height) at the bottom right, the 2-D view, that the bottom letter moves left of
    and the right one above."""
    if not letters:
        return
    x, y, width, height = view
    draw_list = imgui.get_background_draw_list()
    for edge, text in letters.items():
        size = imgui.calc_text_size(text)
        centre_x, centre_y = x + (width - size.x) / 2, y + (height - size.y) / 2
        position = {"right": (x + width - margin - size.x, centre_y), "left": (x + margin, centre_y),
                    "top": (centre_x, y + margin), "bottom": (centre_x, y + height - margin - size.y)}[edge]
        if avoid is not None and _overlaps(position, size, avoid):
            position = ((min(position[0], avoid[0] - margin - size.x), position[1]) if edge == "bottom" else
                        (position[0], min(position[1], avoid[1] - margin - size.y)))
        if shadow:
            for dx, dy in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                draw_list.add_text(imgui.ImVec2(position[0] + dx, position[1] + dy), SHADOW_COLOR, text)
        draw_list.add_text(imgui.ImVec2(*position), LABEL_COLOR, text)


def _overlaps(position, size, box) -> bool:
    return (position[0] < box[0] + box[2] and box[0] < position[0] + size.x
            and position[1] < box[1] + box[3] and box[1] < position[1] + size.y)


def inset_view(slices, spacing) -> tuple[float, float, float, float] | None:
    """Where the 2-D view of `slices` (SliceSettings) sits, in imgui units (x, y, width, height from the
    top left): gfx/slices.py's `inset_box` of the whole framebuffer, as the renderer places it."""
    axis = slices.inset_axis()
    if axis is None:
        return None
    io = imgui.get_io()
    scale_x, scale_y = io.display_framebuffer_scale.x or 1.0, io.display_framebuffer_scale.y or 1.0
    framebuffer = (int(round(io.display_size.x * scale_x)), int(round(io.display_size.y * scale_y)))
    x, y, width, height = inset_box(slices.shape, spacing, axis, (0, 0, *framebuffer))
    return x / scale_x, (framebuffer[1] - y - height) / scale_y, width / scale_x, height / scale_y


def draw_orientation(volume, camera, view: tuple[float, float, float, float], slices=None) -> None:
    """The letters for `volume` (or none) seen through `camera`, drawn around `view`; with `slices`
    (SliceSettings), the 2-D view's letters inside its frame too."""
    if volume is None or volume.world is None or volume.world[1] not in _AXIS_LETTERS:
        return
    box = inset_view(slices, volume.spacing) if slices is not None else None
    draw_screen_letters(screen_letters(volume.world, volume.spacing, *camera.screen_axes()), view, avoid=box)
    if box is not None:
        draw_screen_letters(inset_letters(volume.world, volume.spacing, slices.inset_axis()), box,
                            INSET_LABEL_MARGIN, shadow=True)
