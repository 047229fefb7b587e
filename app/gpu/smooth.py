"""Smoothing projected onto the level set, on the GPU: a `GpuMesh` smoothed in place.

The volume is a `ResidentVolume` (resident.py), usually an extractor's; the mesh is usually its last
extraction (any indexed mesh on that volume's level set works).  Passes (shaders/smooth_*.comp;
numpy mirror and the method: isoscope.cpu.smooth):

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
from ..core.smoothing import (
    ACCEPT,
    BORDER,
    CONVERGED,
    CORRECTION,
    FLOOR_SQUARED,
    NEWTON_STEPS,
    UMBRELLA_WEIGHT,
    check_iterations,
)
from ..errors import InputError
from .buffers import GrowableBuffer
from .limits import GPULimitError, GpuLimits
from .mesh import GpuMesh
from .programs import compute_program, dispatch_groups, set_uniforms
from .resident import ResidentVolume, resident_of
from .scan import ExclusiveScan

IMAGE_SHIFT = 12
"""Position and neighbour images are 2^12 = 4096 texels wide."""

PASSES = ("smooth_valence", "smooth_fill", "smooth_load", "smooth_step", "smooth_keep", "smooth_store")


class Smoother:
    """Smooths meshes on the level sets of one resident volume on the GPU; keeps its scratch between calls.

    >>> smoother = Smoother(volume)                 # a ResidentVolume (or an extractor: its resident volume)
    >>> extractor.extract(level); smoother.smooth(extractor.mesh, 5, level)   # the mesh is changed in place

    Made from an extractor, `smooth`'s level defaults to that extractor's last one.
    """

    def __init__(self, volume: ResidentVolume):
        self.volume = resident_of(volume)
        self._extractor = None if volume is self.volume else volume  # only for smooth's default level
        self.ctx = self.volume.ctx
        self._programs = {name: compute_program(self.ctx, f"{name}.comp", {
            **self.volume.defines, "UMBRELLA_WEIGHT": f"{UMBRELLA_WEIGHT!r}",
            "NEWTON_STEPS": NEWTON_STEPS, "CONVERGED": f"{CONVERGED!r}", "BORDER": f"{BORDER!r}",
            "FLOOR_SQUARED": f"{FLOOR_SQUARED!r}", "IMAGE_SHIFT": IMAGE_SHIFT}) for name in PASSES}
        self._scan = ExclusiveScan(self.ctx)
        self._ends = GrowableBuffer(self.ctx)
        self._images: dict[str, moderngl.Texture] = {}
        self._limits = GpuLimits.of(self.ctx)

    def _image(self, name: str, items: int, components: int, dtype: str) -> moderngl.Texture:
        """A 2-D image of at least `items` texels, 2^IMAGE_SHIFT wide (grown by half again)."""
        rows = -(-items >> IMAGE_SHIFT) or 1
        image = self._images.pop(name, None)
        if image is None or image.height < rows:
            held = 0
            if image is not None:
                held = image.height
                image.release()
            rows = min(max(rows, int(held * 1.5)), self._limits.max_texture_size)
            image = self.ctx.texture((1 << IMAGE_SHIFT, rows), components, dtype=dtype)
        self._images[name] = image
        return image

    def smooth(self, mesh: GpuMesh, iterations: int, level: float | None = None) -> None:
        """`iterations` rounds of smoothing, each projected onto `level` (default: the last level of the
        extractor this smoother was made from)."""
        iterations = check_iterations(iterations)
        volume = self.volume
        if level is None and self._extractor is not None:
            level = self._extractor.level
        if level is None:
            raise InputError("smoothing needs a level: extract one first, or pass level=")
        if iterations == 0 or mesh.n_vertices == 0:
            return
        n_v, n_t = mesh.n_vertices, mesh.n_triangles
        block, rows = self._limits.max_storage_block_bytes, self._limits.max_texture_size
        if max(n_v * VERTEX_BYTES, n_t * 12) > block or 3 * n_t > rows << IMAGE_SHIFT:
            raise GPULimitError(f"smoothing needs the whole mesh ({n_v:,} vertices, {n_t:,} triangles) in one "
                                f"storage block of {block >> 20} MiB; crop or downsample the volume, or use "
                                "backend='cpu', which has no such limit")
        sign = volume.sign
        low, high = volume.value_range
        for program in self._programs.values():
            set_uniforms(program, **volume.grid_uniforms, u_level=sign * level, u_sign=sign,
                         u_vertex_count=n_v, u_triangle_count=n_t, u_tolerance=ACCEPT * (high - low),
                         u_correction=CORRECTION * (high - low))
        ends = self._ends.ensure((n_v + 1) * 4)
        neighbours = self._image("neighbours", 3 * n_t, 2, "u4")
        ranks = self._image("ranks", 3 * n_t, 1, "u4")
        positions = [self._image("positions", n_v, 4, "f4"), self._image("positions 2", n_v, 4, "f4")]
        moved = self._image("moved", n_v, 4, "f4")
        rings, curvatures = self._image("rings", n_v, 2, "u4"), self._image("curvatures", n_v, 4, "f4")
        volume.bind()
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
        images = sum(image.width * image.height * image.components * 4 for image in self._images.values())
        return images + self._ends.size + self._scan.scratch_bytes()

    def release(self) -> None:
        for image in self._images.values():
            image.release()
        self._images.clear()
        self._ends.release()
        self._scan.release()
