"""Smoothing projected onto the level set, on the GPU: a `GpuMesh` smoothed in place.

The volume is the one already resident in an `Extractor`; the mesh is usually its last
extraction (any indexed mesh on that volume's level set works).  Passes (shaders/smooth_*.comp;
numpy mirror and the method: app/reference_smooth.py):

1. ``smooth_valence`` per triangle: outgoing half-edges per vertex (atomic counts), each half-edge's rank
2. scan              the counts -> each vertex's first slot in the neighbour list
3. ``smooth_load``   per vertex: positions in index units, axes it may move along, its ring's slots,
                     the field's curvature where it starts (for the level's correction)
4. ``smooth_fill``   per triangle: each half-edge's end (and its triangle's third corner) into slot
                     first + rank of its start vertex
5. ``smooth_step``   per vertex, once per iteration: umbrella move, Newton projection: a proposed move
6. ``smooth_keep``   per vertex, once per iteration: the move kept unless one of the vertex's triangles
                     could collapse (ping-pong)
7. ``smooth_store``  per vertex: positions, values and normals back into the mesh

Why a neighbour list (CSR) gathered per vertex rather than scattering each triangle into
fixed-point atomics every iteration: the topology is the same in every iteration, so the list
is built once (two passes over the triangles) and each iteration is one pass that reads each
vertex's ~6 neighbours, with no atomics, no clearing pass and no fixed-point rounding; the
projection fits in the same pass.  The check that no triangle collapses needs every vertex's
proposed move, so it is a second dispatch per iteration.
Positions (two, ping-pong, and the proposed moves), rings, curvatures, neighbour lists and ranks
live in 2-D images (an imageLoad costs llvmpipe a fraction of an SSBO load), the per-vertex list
ends in a buffer (it is scanned): 76 bytes of scratch per vertex and 36 per triangle.
"""
from __future__ import annotations

import moderngl

from ..core.layout import GROUP_SIZE, VERTEX_BYTES, ImageUnit, StorageBlock
from ..cpu.smooth import (
    ACCEPT,
    BORDER,
    CONVERGED,
    CORRECTION,
    FLOOR_SQUARED,
    NEWTON_STEPS,
    UMBRELLA_WEIGHT,
    check_iterations,
)
from .limits import GPULimitError, GpuLimits
from .mesh import GpuMesh
from .programs import compute_program, dispatch_groups, set_uniforms
from .scan import ExclusiveScan

IMAGE_SHIFT = 12
"""Position and neighbour images are 2^12 = 4096 texels wide."""

PASSES = ("smooth_valence", "smooth_fill", "smooth_load", "smooth_step", "smooth_keep", "smooth_store")


class Smoother:
    """Smooths meshes of one extractor's volume on the GPU; keeps its scratch buffers between calls.

    >>> smoother = Smoother(extractor)
    >>> extractor.extract(level); smoother.smooth(extractor.mesh, 5)   # the mesh is changed in place
    """

    def __init__(self, extractor):
        self.extractor = extractor
        self.ctx = extractor.ctx
        self._programs = {name: compute_program(self.ctx, f"{name}.comp", {
            **extractor.volume_defines, "UMBRELLA_WEIGHT": f"{UMBRELLA_WEIGHT!r}",
            "NEWTON_STEPS": NEWTON_STEPS, "CONVERGED": f"{CONVERGED!r}", "BORDER": f"{BORDER!r}",
            "FLOOR_SQUARED": f"{FLOOR_SQUARED!r}", "IMAGE_SHIFT": IMAGE_SHIFT}) for name in PASSES}
        self._scan = ExclusiveScan(self.ctx)
        self._buffers: dict[str, moderngl.Buffer | moderngl.Texture] = {}
        self._limits = GpuLimits.of(self.ctx)

    def _buffer(self, name: str, size: int) -> moderngl.Buffer:
        buf = self._buffers.get(name)
        if buf is None or buf.size < size:
            if buf is not None:
                buf.release()
            buf = self._buffers[name] = self.ctx.buffer(reserve=max(size, 4))
        return buf

    def _image(self, name: str, items: int, components: int, dtype: str) -> moderngl.Texture:
        """A 2-D image of at least `items` texels, 2^IMAGE_SHIFT wide (grown by half again)."""
        rows = -(-items >> IMAGE_SHIFT) or 1
        image = self._buffers.get(name)
        if image is None or image.height < rows:
            if image is not None:
                image.release()
            rows = min(max(rows, int((image.height if image else 0) * 1.5)), self._limits.max_texture_size)
            image = self._buffers[name] = self.ctx.texture((1 << IMAGE_SHIFT, rows), components, dtype=dtype)
        return image

    def smooth(self, mesh: GpuMesh, iterations: int, level: float | None = None) -> None:
        """`iterations` rounds of smoothing, each projected onto `level` (default: the extractor's last)."""
        iterations = check_iterations(iterations)
        ex = self.extractor
        level = ex.level if level is None else level
        if level is None:
            raise ValueError("smoothing needs a level: extract one first, or pass level=")
        if iterations == 0 or mesh.n_vertices == 0:
            return
        n_v, n_t = mesh.n_vertices, mesh.n_triangles
        block, rows = self._limits.max_storage_block_bytes, self._limits.max_texture_size
        if max(n_v * VERTEX_BYTES, n_t * 12) > block or 3 * n_t > rows << IMAGE_SHIFT:
            raise GPULimitError(f"smoothing needs the whole mesh ({n_v:,} vertices, {n_t:,} triangles) in one "
                                f"storage block of {block >> 20} MiB; crop or downsample the volume, or use "
                                "backend='cpu', which has no such limit")
        sign = 1.0 if ex.descent else -1.0
        low, high = ex.value_range
        for program in self._programs.values():
            set_uniforms(program, **ex.grid_uniforms, u_level=sign * level, u_sign=sign,
                         u_vertex_count=n_v, u_triangle_count=n_t, u_tolerance=ACCEPT * (high - low),
                         u_correction=CORRECTION * (high - low))
        ends = self._buffer("ends", (n_v + 1) * 4)
        neighbours = self._image("neighbours", 3 * n_t, 2, "u4")
        ranks = self._image("ranks", 3 * n_t, 1, "u4")
        positions = [self._image("positions", n_v, 4, "f4"), self._image("positions 2", n_v, 4, "f4")]
        moved = self._image("moved", n_v, 4, "f4")
        rings, curvatures = self._image("rings", n_v, 2, "u4"), self._image("curvatures", n_v, 4, "f4")
        ex.volume_texture.bind_to_image(ImageUnit.VOLUME, read=True, write=False)
        mesh.index_buffer.bind_to_storage_buffer(StorageBlock.MESH_INDICES, size=max(n_t, 1) * 12)
        mesh.vertex_buffer.bind_to_storage_buffer(StorageBlock.MESH_VERTICES, size=n_v * VERTEX_BYTES)

        ends.clear()
        ends.bind_to_storage_buffer(StorageBlock.ENDS)
        ranks.bind_to_image(ImageUnit.RANKS, read=False, write=True)
        self._run("smooth_valence", n_t)
        self._scan(ends, n_v + 1)
        ends.bind_to_storage_buffer(StorageBlock.ENDS)
        positions[0].bind_to_image(ImageUnit.POSITIONS, read=False, write=True)
        rings.bind_to_image(ImageUnit.RINGS, read=False, write=True)
        curvatures.bind_to_image(ImageUnit.CURVATURES, read=False, write=True)
        self._run("smooth_load", n_v)
        neighbours.bind_to_image(ImageUnit.NEIGHBOURS, read=False, write=True)
        rings.bind_to_image(ImageUnit.RINGS, read=True, write=False)
        ranks.bind_to_image(ImageUnit.RANKS, read=True, write=False)
        self._run("smooth_fill", n_t)
        neighbours.bind_to_image(ImageUnit.NEIGHBOURS, read=True, write=False)
        curvatures.bind_to_image(ImageUnit.CURVATURES, read=True, write=False)
        moved.bind_to_image(ImageUnit.MOVED, read=True, write=True)  # written by smooth_step, read by smooth_keep
        for i in range(iterations):
            positions[i % 2].bind_to_image(ImageUnit.POSITIONS, read=True, write=False)
            positions[(i + 1) % 2].bind_to_image(ImageUnit.NEXT_POSITIONS, read=False, write=True)
            self._run("smooth_step", n_v)
            self._run("smooth_keep", n_v)
        positions[iterations % 2].bind_to_image(ImageUnit.POSITIONS, read=True, write=False)
        self._run("smooth_store", n_v)
        self.ctx.finish()

    def _run(self, name: str, items: int) -> None:
        dispatch_groups(self._programs[name], -(-items // GROUP_SIZE))
        self.ctx.memory_barrier()

    def scratch_bytes(self) -> int:
        sizes = [b.size if isinstance(b, moderngl.Buffer) else b.width * b.height * b.components * 4
                 for b in self._buffers.values()]
        return sum(sizes) + self._scan.scratch_bytes()

    def release(self) -> None:
        for buf in self._buffers.values():
            buf.release()
        self._buffers.clear()
        self._scan.release()
