"""A big label map in the window: after a label is shown, hidden or faded, the frames draw its coarse twins
(every n-th sample) until it rests, so a toggle shows at once on a software renderer; the full surfaces come
back after REST_S, a render (wait) always draws them, and no toggle extracts anything."""
from __future__ import annotations

import contextlib

import numpy as np
import pytest

from isoscope.volumes.inputs import as_volume


def two_blobs(n: int = 48) -> np.ndarray:
    x, y, z = np.mgrid[:n, :n, :n]
    labels = np.zeros((n, n, n), np.uint8)
    labels[(x - 16) ** 2 + (y - 24) ** 2 + (z - 24) ** 2 < 12 ** 2] = 3
    labels[(x - 33) ** 2 + (y - 24) ** 2 + (z - 24) ** 2 < 11 ** 2] = 9
    return labels


@contextlib.contextmanager
def two_blobs_shown(gl_ctx, previews: bool):
    """(state, scene): a viewer's model and its scene showing two_blobs() as labels, the first frame made."""
    from isoscope.viewer.gfx.scene import GpuScene
    from isoscope.viewer.model.state import ViewerState
    state = ViewerState()
    scene = GpuScene(gl_ctx, state, previews=previews)
    try:
        scene.show(as_volume(two_blobs()))
        state.show_labels()
        scene.update(0.0)
        yield state, scene
    finally:
        scene.release()


@pytest.mark.gl
def test_a_toggle_draws_the_coarse_twins_until_the_labels_rest(gl_ctx, monkeypatch):
    import isoscope.viewer.gfx.label_scene as label_scene
    from isoscope.gpu.context import is_software_renderer
    from isoscope.viewer.gfx.scene import REST_S
    if not is_software_renderer(gl_ctx):
        pytest.skip("coarse twins are for software renderers, where a frame of a big label map is slow")
    monkeypatch.setattr(label_scene, "PREVIEW_TRIANGLES", 2_000)   # these small blobs count as big
    with two_blobs_shown(gl_ctx, previews=True) as (state, scene):
        meshes = scene.labels
        assert meshes.preview_step >= 2 and sorted(meshes.coarse) == [3, 9]
        full = {label: mesh.n_triangles for label, mesh in meshes.meshes.items()}
        assert all(meshes.coarse[label].n_triangles * 2 < full[label] for label in full)   # coarser: fewer
        made = meshes.extractions

        def drawn_triangles():
            return [mesh.n_triangles for mesh, _ in scene.drawn()]

        assert drawn_triangles() == [full[3], full[9]]        # at rest: the full surfaces
        state.labels.set_visible(3, False)
        scene.update(1 / 60)
        assert drawn_triangles() == [meshes.coarse[9].n_triangles]   # just toggled: the coarse twin
        state.labels.set_opacity(9, 0.5)
        scene.update(REST_S * 0.5)
        assert drawn_triangles() == [meshes.coarse[9].n_triangles]   # faded: rests again from zero
        scene.update(REST_S * 0.9)
        assert drawn_triangles() == [meshes.coarse[9].n_triangles]   # not yet rested
        scene.update(REST_S * 0.2)
        assert drawn_triangles() == [full[9]]                 # rested: the full surface again
        state.labels.set_visible(3, True)
        scene.update(0.0, wait=True)                           # a render waits: always the full ones
        assert drawn_triangles() == [full[3], full[9]]
        assert meshes.extractions == made                      # no toggle made a mesh


@pytest.mark.gl
def test_a_small_label_map_or_a_render_makes_no_coarse_twins(gl_ctx):
    for previews in (True, False):
        with two_blobs_shown(gl_ctx, previews) as (_, scene):
            assert scene.labels.coarse == {} and scene.labels.preview_step == 1
