"""The buffers an extraction writes: the mesh (vertices, indices) and the vertex jobs between passes 7 and 8.

They grow with the mesh (buffers.GrowableBuffer) and may outgrow one storage block: the passes then
bind them a window at a time (`bind_window`).  `MeshOutputs` owns the three and releases them.
"""
from __future__ import annotations

import moderngl

from ..core.layout import INDEX_BYTES, VERTEX_BYTES
from .buffers import GrowableBuffer
from .limits import GPULimitError


class MeshOutputs:
    """An extractor's vertex, index and vertex-job buffers, `job_record_bytes` a job."""

    def __init__(self, ctx: moderngl.Context, job_record_bytes: int, own_job_bytes: int = 0):
        self.job_record_bytes = job_record_bytes
        self.own_job_bytes = own_job_bytes  # per own vertex of a cell (CellKind.own_vertices), if any
        self.buffers: dict[str, GrowableBuffer] = {}
        for name, minimum in (("vertices", VERTEX_BYTES), ("indices", INDEX_BYTES), ("jobs", job_record_bytes),
                              ("own jobs", own_job_bytes)):
            if minimum:
                self.buffers[name] = GrowableBuffer(ctx, minimum)

    # None only after release, or where a failed allocation left none.
    @property
    def vertex_buffer(self) -> moderngl.Buffer | None:
        return self.buffers["vertices"].buffer if self.buffers else None

    @property
    def index_buffer(self) -> moderngl.Buffer | None:
        return self.buffers["indices"].buffer if self.buffers else None

    @property
    def jobs(self) -> moderngl.Buffer | None:
        return self.buffers["jobs"].buffer if self.buffers else None

    @property
    def own_jobs(self) -> moderngl.Buffer | None:
        return self.buffers["own jobs"].buffer if "own jobs" in self.buffers else None

    def ensure(self, n_vertices: int, n_triangles: int, n_own: int = 0) -> None:
        """Grow the buffers to fit a mesh of this size (`n_own` of its vertices cells' own).  A failed
        allocation raises GPULimitError and leaves small buffers where they can be had."""
        for name, needed in (("vertices", n_vertices * VERTEX_BYTES), ("indices", n_triangles * INDEX_BYTES),
                             ("jobs", n_vertices * self.job_record_bytes), ("own jobs", n_own * self.own_job_bytes)):
            if name not in self.buffers:
                continue
            try:
                self.buffers[name].ensure(needed)
            except moderngl.Error as exc:
                raise GPULimitError(
                    f"the mesh at this level ({n_vertices} vertices, {n_triangles} triangles) needs a "
                    f"{max(needed, 1) / 2**20:.1f} MiB buffer that this GPU could not allocate ({exc}); pick "
                    "another level, crop or downsample the volume, or use backend='cpu'") from None

    @staticmethod
    def bind_window(binding: int, buffer: moderngl.Buffer, window: tuple[int, int], record_bytes: int) -> None:
        """Bind records first .. first + count of `buffer` (one record for an empty window)."""
        first, count = window
        buffer.bind_to_storage_buffer(binding, offset=first * record_bytes, size=max(count, 1) * record_bytes)

    def job_bytes(self) -> int:
        """The vertex-job buffers' sizes: job_record_bytes per vertex (and own_job_bytes per own vertex), grown
        with the mesh."""
        return sum(self.buffers[name].size for name in ("jobs", "own jobs") if name in self.buffers)

    def mesh_bytes(self) -> int:
        """The vertex and index buffers' sizes."""
        return sum(self.buffers[name].size for name in ("vertices", "indices")) if self.buffers else 0

    def release(self) -> None:
        for buffer in self.buffers.values():
            buffer.release()
        self.buffers.clear()
