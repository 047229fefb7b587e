"""Extended Marching Cubes for the GPU extractor's meshes, and `isoscope render --sharp`.

The feature step (app.reference_sharp) runs in numpy on the mesh the Extractor read back;
there are no emc_* compute shaders yet.  For drawing, triangles at feature vertices get
face normals (reference_sharp.crisp_normals), so edges render crisp.
"""
from __future__ import annotations

import numpy as np

from .gpu_layout import VERTEX_FLOATS
from .mesh import GpuMesh
from .reference_sharp import crisp_normals, sharpen_extracted


def sharp_mesh_of(extractor, volume_data, angle):
    """The extractor's last mesh with sharp features: verts, faces, normals, values, n_plain_vertices."""
    return sharpen_extracted(extractor.read_mesh(), volume_data, extractor.spacing, extractor.descent, angle)


def upload_mesh(ctx, verts, faces, normals, values) -> GpuMesh:
    """Numpy arrays -> a GpuMesh in new buffers (the caller releases them)."""
    records = np.zeros((len(verts), VERTEX_FLOATS), np.float32)
    records[:, 0:3], records[:, 3], records[:, 4:7] = verts, values, normals
    return GpuMesh(ctx.buffer(records.tobytes()), ctx.buffer(faces.astype(np.uint32).tobytes()),
                   len(verts), len(faces))


def render_sharp_png(volume, out, iso, angle, size=(800, 600), azimuth=None, elevation=None,
                     transparent: bool = False):
    """`viewer.headless.render_png`, drawing the Extended-MC mesh (crisp normals) instead of the plain one."""
    from .viewer.headless import HeadlessViewer
    from .viewer.screenshot import save_png
    viewer = HeadlessViewer(size)
    mesh = None
    try:
        viewer.state.style.transparent_background = transparent
        viewer.show(volume, iso, azimuth, elevation)
        extractor = viewer.state.extractor
        mesh = upload_mesh(viewer.ctx, *crisp_normals(*sharp_mesh_of(extractor, volume.data, angle)))
        viewer.target.use()
        viewer.renderer.draw([mesh], viewer.camera, viewer.target.viewport, viewer.state.style)
        target = viewer.target
        return save_png(target.read_rgba() if transparent else target.read_rgb(), out)
    finally:
        if mesh is not None:
            mesh.vertex_buffer.release()
            mesh.index_buffer.release()
        viewer.release()
