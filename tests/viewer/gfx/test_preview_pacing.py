"""A moving level's preview step follows the measured frame times, and the mesh at rest is the library's
(issue 33, point 2), in a headless viewer with the window's previews: frames are "timed" by the `dt` each
frame is given, as the window gives the last frame's duration."""
from __future__ import annotations

import numpy as np
import pytest

import isoscope
from isoscope.viewer.gfx.scene import REST_S
from isoscope.viewer.gfx.surface import coarsest_step
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume

SHAPE = (90, 76, 64)


@pytest.fixture(scope="module")
def field():
    """Smooth blobs in a box of three different sides (an axis mixed up would show), C order, float32."""
    x, y, z = np.meshgrid(*(np.linspace(-1, 1, n, dtype=np.float32) for n in SHAPE), indexing="ij")
    return (np.sin(5 * x) * np.cos(4 * y) + np.sin(3 * z + x) + 0.6 * np.cos(6 * y * z)).astype(np.float32)


@pytest.fixture
def viewer(gl_ctx):
    made = HeadlessViewer((200, 150), ctx=gl_ctx, previews=True)
    yield made
    made.release()


def outward(data, level, step=1):
    """What `isoscope export` writes (the API's outward mesh) of every step-th sample, in the full volume's units."""
    verts, faces, _, _ = isoscope.api.outward_marching_cubes(data[::step, ::step, ::step], level,
                                                             spacing=(float(step),) * 3, backend="cpu")
    return verts, faces


def drag(viewer, values, frame_s):
    """Frames moving the selected level through `values`, each said to have taken `frame_s`; the steps drawn."""
    steps = []
    for value in values:
        viewer.state.iso = value
        viewer.app.follow(frame_s)
        steps.append(viewer.scene.stats.preview_step)
    return steps


def test_slow_frames_coarsen_the_preview_and_the_rested_mesh_is_export_s(viewer, field):
    viewer.show(as_volume(field), 0.0)
    scene, state = viewer.scene, viewer.state
    full = scene.stats.n_triangles
    assert scene.stats.preview_step == 1 and full > 20_000
    values = np.linspace(0.02, 0.5, 24)
    steps = drag(viewer, values, frame_s=0.25)   # 250 ms frames: far over the target
    assert steps[0] >= 1 and steps[-1] == coarsest_step(SHAPE) > 2
    assert all(b >= a for a, b in zip(steps, steps[1:]))   # coarser as the slow frames are measured
    step = steps[-1]
    # the preview on show is the mesh of every step-th sample, in the full volume's units
    verts, faces, _, _ = scene.surface.shown.read_mesh()
    want = outward(field, values[-1], step)
    np.testing.assert_array_equal(faces, want[1])
    np.testing.assert_allclose(verts, want[0], atol=1e-4)
    coarse = viewer.render()

    assert viewer.scene.update(REST_S) is False and scene.stats.preview_step == step   # rested: the status line says so
    assert state.message == f"full resolution: extracting {'x'.join(map(str, SHAPE))} samples..."
    assert viewer.scene.update(0.02) is False and scene.stats.preview_step == step     # a frame shows the word
    viewer.app.follow(0.02)                                                   # the next makes the mesh
    assert scene.stats.preview_step == 1 and scene.stats.shown_shape == SHAPE
    assert state.message == f"full resolution: {scene.stats.n_triangles:,} triangles in {scene.stats.extract_ms:.0f} ms"
    verts, faces, _, _ = scene.surface.shown.read_mesh()
    want = outward(field, values[-1])
    np.testing.assert_array_equal(faces, want[1])
    np.testing.assert_allclose(verts, want[0], atol=1e-4)
    # scikit-image's call gives the same triangles, wound the other way
    np.testing.assert_array_equal(faces, isoscope.marching_cubes(field, values[-1], backend="cpu")[1][:, ::-1])
    fine = viewer.render()
    # both pictures show the surface, the same one: the coarse one differs from the full one in some pixels
    background = fine[0, 0].astype(int)
    for picture in (coarse, fine):
        assert (np.abs(picture.astype(int) - background).sum(axis=2) > 30).mean() > 0.05
    differs = np.abs(coarse.astype(int) - fine.astype(int)).sum(axis=2) > 30
    assert 0.005 < differs.mean() < 0.5

    drag(viewer, values[::-1][:3], frame_s=0.25)   # moving again: the last full mesh's word goes
    assert scene.stats.preview_step > 1 and state.message is None


def test_fast_frames_refine_the_preview_down_to_full_resolution(viewer, field, monkeypatch):
    import isoscope.viewer.gfx.surface as surface_module
    monkeypatch.setattr(surface_module, "PREVIEW_TRIANGLES", 500)   # the first guess: a coarse preview
    viewer.show(as_volume(field), 0.0)
    steps = drag(viewer, np.linspace(0.02, 0.5, 24), frame_s=0.004)   # 4 ms frames: room for every sample
    assert steps[0] > 3 and steps[-1] == 1
    assert all(b <= a for a, b in zip(steps, steps[1:]))
    # moving at full resolution: nothing to bring back at rest
    assert viewer.scene.update(REST_S) is False and viewer.scene.stats.preview_step == 1
    assert viewer.state.message is None
