"""The viewer's process within its memory budget on a software renderer (issue 33: "a small --memory-budget
forces bricks, keeps RSS within it, plus a stated overhead")."""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume


@pytest.fixture(scope="module")
def wrinkled():
    """A ball with a ripple, 96^3 float32: ~60 k triangles at level 0, many of them in front of others."""
    axis = np.linspace(-1, 1, 96, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return (0.7 - np.sqrt(x * x + y * y + z * z) + 0.05 * np.sin(9 * x) * np.sin(9 * y) * np.sin(9 * z)
            ).astype(np.float32)


@pytest.mark.parametrize("style", ["opaque", "wireframe", "translucent"])
def test_drawing_in_chunks_with_waits_between_gives_the_same_picture(gl_ctx, wrinkled, style):
    """The renderer waits for the GL every SOFTWARE_DRAW_TRIANGLES on llvmpipe (renderer.DrawPacer); a mesh
    drawn in pieces of 997 triangles, each piece from its own first triangle, is the mesh drawn whole."""
    viewer = HeadlessViewer((320, 240), ctx=gl_ctx)
    try:
        viewer.show(as_volume(wrinkled, name="wrinkled"), 0.0)
        if style == "wireframe":
            viewer.state.style.wireframe = True
        if style == "translucent":
            viewer.state.levels.set_opacity(0, 0.5)
        pacer = viewer.renderer.pacer
        pacer.every = 0
        whole = viewer.render()
        triangles = sum(mesh.n_triangles for mesh in viewer.scene.stats.meshes)
        pacer.every = 997
        pieces = viewer.render()
    finally:
        viewer.release()
    assert triangles > 20 * 997
    assert (whole != whole[0, 0]).any(axis=2).mean() > 0.05   # the surface is drawn
    np.testing.assert_array_equal(pieces, whole)
