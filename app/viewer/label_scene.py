"""Label maps on screen: each label's surface uploaded as a `GpuMesh` with its own colour.

`label_scene` is what a view of a label map needs (the headless render uses it; the viewer's
panel can too); `render_labels_png` draws one to a PNG, as `isoscope render --labels` does.
"""
from __future__ import annotations

from ..labels import label_colors, label_surfaces, labels_of
from ..mesh import GpuMesh
from .levels import SurfaceLook
from .screenshot import save_png


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


def render_labels_png(volume, out, size=(800, 600), azimuth=None, elevation=None, transparent: bool = False):
    """Render every non-zero label of `volume` as its own coloured surface to the PNG `out`."""
    from .headless import HeadlessViewer
    surfaces = label_surfaces(labels_of(volume), spacing=volume.spacing)
    if not surfaces:
        raise ValueError(f"{volume.name} has no non-zero labels, so no surface to draw; leave out --labels "
                         "to draw an isosurface")
    viewer = HeadlessViewer(size)
    scene = []
    try:
        style = viewer.state.style
        style.transparent_background = transparent
        upper = tuple((n - 1) * s for n, s in zip(volume.data.shape, volume.spacing))
        viewer.camera.fit((0.0, 0.0, 0.0), upper, azimuth, elevation)
        viewer.renderer.set_box((0.0, 0.0, 0.0), upper)
        scene = label_scene(viewer.ctx, surfaces)
        viewer.target.use()
        viewer.renderer.draw([mesh for _, mesh, _ in scene], viewer.camera, viewer.target.viewport, style,
                             looks=[SurfaceLook(tuple(color), 1.0) for _, _, color in scene])
        return save_png(viewer.target.read_rgba() if transparent else viewer.target.read_rgb(), out)
    finally:
        release_scene(scene)
        viewer.release()
