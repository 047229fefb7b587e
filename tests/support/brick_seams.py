"""Pictures of a volume shown in bricks with seams between levels: what a crack would show."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def drawn(viewer) -> np.ndarray:
    """The scene's buffers drawn as they are (no frame's follow: the state is not looked at again)."""
    viewer.target.use()
    viewer.app.draw(viewer.target.viewport)
    return viewer.target.read_rgb()


@dataclass
class SeamPixels:
    """`drawn`: pixels not background in the mixed picture; `holes`: background there where both the all-coarse and
    the all-fine pictures show the surface; `cracks`: the inside's (orange back face) colour there where neither
    shows it."""
    drawn: int
    holes: int
    cracks: int


def chequer_seams(viewer) -> SeamPixels:
    """Draw a headless viewer's volume (shown in bricks, nothing refined yet) all coarse, then all refined (a
    render), then a chequer of refined and coarse bricks (seams along every axis), and count the faults of the
    chequer's picture.  Every brick must be refined by the render."""
    state = viewer.state
    coarse_only = drawn(viewer)   # the coarse mesh alone: shown, no frame has refined a brick yet
    fine = viewer.render()
    bricks = state.bricks
    assert len(bricks.meshes) == len(bricks.bricks)
    for index in [index for index in bricks.meshes if sum(index) % 2]:
        del bricks.meshes[index]
    bricks.serial += 1
    viewer.scene.follow_bricks()
    mixed = drawn(viewer)
    assert 0 < len(bricks.meshes) < len(bricks.bricks) and viewer.scene.bricks.drawing
    background = np.array(state.style.background) * 255
    is_background = [np.all(np.abs(image.astype(float) - background) < 3, axis=2)
                     for image in (coarse_only, fine, mixed)]
    inside = [image[..., 0].astype(int) - image[..., 2] > 40 for image in (coarse_only, fine, mixed)]  # orange
    assert np.array(state.style.back_color)[0] > 0.8 > np.array(state.style.front_color)[0]
    holes = is_background[2] & ~is_background[0] & ~is_background[1]
    cracks = inside[2] & ~inside[0] & ~inside[1]
    return SeamPixels(int((~is_background[2]).sum()), int(holes.sum()), int(cracks.sum()))
