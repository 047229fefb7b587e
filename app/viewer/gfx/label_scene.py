"""Label maps on screen: each label's surface uploaded as a `GpuMesh` with its own colour.

`label_scene` is what a view of a label map needs (the headless render uses it; the viewer's
panel can too); `headless.render_labels_png` draws one to a PNG, as `isoscope render --labels` does.
"""
from __future__ import annotations

from ...gpu.mesh import GpuMesh
from ...labels import label_colors


def label_scene(ctx, surfaces: dict) -> list[tuple[int, GpuMesh, tuple[float, float, float]]]:
    """(label, mesh on the GPU, RGB colour) per label of `label_surfaces`' result, in label order.
    The caller owns the buffers (release them with `release_scene`)."""
    scene = []
    try:
        for label, color in zip(sorted(surfaces), label_colors(len(surfaces))):
            scene.append((label, GpuMesh.upload(ctx, *surfaces[label], float(label)), tuple(map(float, color))))
    except BaseException:   # out of GPU memory half-way: nothing half-made is left behind
        release_scene(scene)
        raise
    return scene


def release_scene(scene) -> None:
    for _, mesh, _ in scene:
        mesh.release()
