"""The mesh contract between what makes meshes on the GPU and what draws or reads them.

An extractor produces a `GpuMesh`; the renderer draws any number of them, and
`read()` brings one back as numpy arrays.  Nothing else about its maker is assumed,
so several meshes per volume (levels, labels, chunks, a coarse preview) are just
several records.

Who frees the buffers is said by the type: a `GpuMesh` is a view of buffers that belong to
someone else (an extractor's, reused for its next mesh), and has no `release`; an `OwnedMesh`
(what `GpuMesh.upload` makes) owns its buffers, and whoever holds it releases it.
"""
from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..core.layout import INDEX_BYTES, VERTEX_BYTES, VERTEX_FIELDS, VERTEX_FLOATS, VERTEX_FORMAT
from ..errors import InputError
from .context import is_software_renderer


def empty_mesh():
    """verts, faces, normals, values of a level with no surface."""
    return (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32),
            np.zeros((0, 3), np.float32), np.zeros((0,), np.float32))


def vertex_records(verts, normals, values=0.0) -> np.ndarray:
    """(N, VERTEX_FLOATS) float32: each vertex's record as a vertex buffer holds it (layout.VERTEX_FIELDS)."""
    records = np.zeros((len(verts), VERTEX_FLOATS), np.float32)
    start = 0
    for name, width in VERTEX_FIELDS:
        column = {"position": verts, "value": values, "normal": normals}.get(name, 0.0)  # "" pads
        records[:, start:start + width] = np.reshape(column, (-1, width)) if np.ndim(column) else column
        start += width
    return records


@dataclass(frozen=True)
class GpuMesh:
    """An indexed triangle mesh in GPU buffers.

    `vertex_buffer` holds `n_vertices` records of `vertex_format` (see layout.VERTEX_FIELDS:
    position, value, normal), `index_buffer` `n_triangles` triples of uint32 vertex indices from its
    `first_triangle`-th on (a range of a larger mesh's triangles: 0 for all of them).
    The buffers belong to the mesh's maker, which may reuse them for its next mesh: a view.
    """
    vertex_buffer: moderngl.Buffer
    index_buffer: moderngl.Buffer
    n_vertices: int
    n_triangles: int
    vertex_format: str = VERTEX_FORMAT
    first_triangle: int = 0

    @classmethod
    def upload(cls, ctx: moderngl.Context, verts, faces, normals, values=0.0) -> OwnedMesh:
        """Numpy arrays (or one value for every vertex) into new buffers of `ctx`: an `OwnedMesh`,
        which the caller releases."""
        faces = np.ascontiguousarray(faces, np.uint32)
        vertex_buffer = ctx.buffer(vertex_records(verts, normals, values).tobytes())
        try:
            index_buffer = ctx.buffer(faces.tobytes())
        except BaseException:
            vertex_buffer.release()
            raise
        return OwnedMesh(vertex_buffer, index_buffer, len(verts), len(faces))

    def read(self):
        """verts (N, 3), faces (M, 3) int32, normals (N, 3), values (N,): scikit-image's layout."""
        if self.vertex_format != VERTEX_FORMAT:
            raise InputError(f"cannot read vertex records of format {self.vertex_format!r}")
        if self.n_vertices == 0:
            return empty_mesh()
        fields = _read_fields(self.vertex_buffer, self.n_vertices)
        # Indices are below 2^31, so the GPU's uint32 triangles are read as the int32 faces they are.
        faces = np.empty((self.n_triangles, 3), np.int32)
        self.index_buffer.read_into(faces, self.n_triangles * INDEX_BYTES, offset=self.first_triangle * INDEX_BYTES)
        return fields["position"], faces, fields["normal"], np.ascontiguousarray(fields["value"][:, 0])


@dataclass(frozen=True)
class OwnedMesh(GpuMesh):
    """A `GpuMesh` whose buffers are its own (`GpuMesh.upload`): its holder releases them."""

    def release(self) -> None:
        self.vertex_buffer.release()
        self.index_buffer.release()


def _read_fields(buffer: moderngl.Buffer, n_vertices: int) -> dict[str, np.ndarray]:
    """Each named field of the first `n_vertices` records, (N, width) float32, C-contiguous.

    On a software renderer each field is copied from the mapped buffer into its own array
    (moderngl's read_chunks_into): on the MNI T1 at 453 k vertices 2.0 ms, against 5.6 for reading
    the records and copying three columns out of them.  But read_chunks_into maps the whole buffer
    (which grows by half again ahead of the mesh), once per field: on a GPU with memory of its own
    that could move it over the bus three times, so there the records are read once, as far as the
    mesh goes, and split in numpy."""
    fields, start = {}, 0
    if is_software_renderer(buffer.ctx):   # buffers in CPU memory: mapping a whole one costs nothing
        for name, width in VERTEX_FIELDS:
            if name:
                fields[name] = np.empty((n_vertices, width), np.float32)
                buffer.read_chunks_into(fields[name], 4 * width, 4 * start, VERTEX_BYTES, n_vertices)
            start += width
        return fields
    records = np.empty((n_vertices, VERTEX_FLOATS), np.float32)
    buffer.read_into(records, n_vertices * VERTEX_BYTES)
    for name, width in VERTEX_FIELDS:
        if name:
            fields[name] = np.ascontiguousarray(records[:, start:start + width])
        start += width
    return fields
