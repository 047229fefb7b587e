"""Each level's mesh on the GPU (GpuScene's): the selected level is drawn straight from the surface's extractor;
every other level keeps its last full-resolution mesh in buffers of its own (`MeshCopy`, a GPU-to-GPU copy made
when it stops being the selected one), so a drag re-extracts one level per frame, not all.
"""
from __future__ import annotations

import moderngl

from ...core.layout import INDEX_BYTES, VERTEX_BYTES
from ...gpu.buffers import GrowableBuffer
from ...gpu.mesh import GpuMesh
from ...options import MeshOptions
from ..model.levels import Level
from . import surface as surface_module

MIN_PREVIEW_SHARE = 8        # the moving level's preview keeps at least 1/8 of the frame's triangle budget


class MeshCopy:
    """A mesh copied on the GPU into buffers of its own (growable: a level dragged back and forth rarely
    reallocates)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._vertices = GrowableBuffer(ctx, VERTEX_BYTES)
        self._indices = GrowableBuffer(ctx, INDEX_BYTES)
        self.n_vertices = self.n_triangles = 0
        self.extract_ms = 0.0       # of the extraction it was copied from

    def take(self, mesh: GpuMesh, extract_ms: float) -> None:
        """Copy `mesh`'s vertices and triangles into these buffers (grown where needed) and keep its counts and
        extraction time."""
        vertex_bytes, index_bytes = mesh.n_vertices * VERTEX_BYTES, mesh.n_triangles * INDEX_BYTES
        vertices, indices = self._vertices.ensure(vertex_bytes), self._indices.ensure(index_bytes)
        if mesh.n_triangles:
            self.ctx.copy_buffer(vertices, mesh.vertex_buffer, vertex_bytes)
            self.ctx.copy_buffer(indices, mesh.index_buffer, index_bytes)
        self.n_vertices, self.n_triangles, self.extract_ms = mesh.n_vertices, mesh.n_triangles, extract_ms

    @property
    def mesh(self) -> GpuMesh:
        """The copy as the renderer draws it."""
        return GpuMesh(self._vertices.buffer, self._indices.buffer, self.n_vertices, self.n_triangles)

    def release(self) -> None:
        """Free the copy's buffers."""
        self._vertices.release()
        self._indices.release()


class LevelMeshes:
    """Which level's mesh the surface's extractor holds (`on_extractor`) and every other level's copy (`copies`)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.on_extractor: Level | None = None   # the level whose mesh the extractor holds
        self.copies: dict[Level, MeshCopy] = {}  # the other levels' meshes

    def keep(self, level: Level, surface, options: MeshOptions) -> None:
        """Copy `level`'s full-resolution mesh (extracted again where the surface shows another) into its
        own buffers."""
        if surface.shown_step != 1 or surface.shown_cells != options.cells or surface.shown.level != level.value:
            surface.extract(level.value, options)
        surface.settle()  # sharp features still on the worker: the copy must have them
        if level not in self.copies:
            self.copies[level] = MeshCopy(self.ctx)
        self.copies[level].take(surface.mesh, surface.shown.last_extract_ms)

    def refresh(self, surface, options: MeshOptions) -> None:
        """Every copy made again from `surface` with `options`."""
        for level, copy in self.copies.items():
            if level is not self.on_extractor:
                surface.extract(level.value, options)
                copy.take(surface.mesh, surface.shown.last_extract_ms)

    def drop_gone(self, levels) -> None:
        """Free the copies of levels no longer in `levels`."""
        for level in [level for level in self.copies if level not in levels]:
            self.copies.pop(level).release()

    def mesh(self, level: Level, surface) -> GpuMesh | None:
        """The mesh drawn for `level`: the extractor's for the selected one, else its copy (None without one)."""
        if surface is None:
            return None
        if level is self.on_extractor:
            return surface.mesh
        copy = self.copies.get(level)
        return copy.mesh if copy is not None else None

    def stats(self, level: Level, surface) -> tuple[int, float]:
        """(triangles, extraction ms) of the mesh on show for `level`."""
        if level is self.on_extractor:
            return (surface.shown.n_triangles, surface.shown.last_extract_ms) if surface is not None else (0, 0.0)
        copy = self.copies.get(level)
        return (copy.n_triangles, copy.extract_ms) if copy is not None else (0, 0.0)

    def preview_budget(self) -> int:
        """Triangles the moving level's preview may have: the frame's budget less what the other
        visible levels draw (full meshes), so a drag's frame time stays bounded with several."""
        others = sum(copy.n_triangles for level, copy in self.copies.items()
                     if level is not self.on_extractor and level.visible and level.opacity > 0)
        budget = surface_module.PREVIEW_TRIANGLES
        return max(budget - others, budget // MIN_PREVIEW_SHARE)

    def release(self) -> None:
        """Free every copy."""
        for copy in self.copies.values():
            copy.release()
        self.copies.clear()
