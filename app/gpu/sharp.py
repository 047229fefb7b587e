"""Extended Marching Cubes' feature step on the GPU, on a mesh of a resident volume (an `Extractor`'s).

    >>> ex = Extractor(volume); ex.extract(level)
    >>> sharp = SharpExtractor(ex.resident)         # reads its volume image
    >>> sharp.may_bend(angle, ex.mesh)              # False: the sharp mesh is the plain one
    >>> sharp.patch_points(...)                     # core.sharp.points.patch_points, on the GPU

Passes (shaders/emc_*.comp; numpy mirror and the method: isoscope.core.sharp):

0. ``emc_flags``  per vertex of the plain mesh: is its normal more than half the feature angle
   from the mean-gradient direction of a cell around its edge (core.sharp.cells.vertex_may_bend)?
   Where no vertex is, no cell's normals open wider than the angle and `sharpen` would return
   the plain mesh: the caller skips the read-back and the numpy step (sphere, gyroid).
1. ``emc_solve``  per feature patch: ENO normals of its vertices and one-ring from the volume
   image, the extreme normals, the planes' least-squares point (a fixed-step Jacobi eigen-solve
   of the 3x3 normal equations, in double precision as numpy's), the line or corner into the cell.

What is not on the GPU yet (numpy, on the mesh read back where pass 0 flags a vertex): finding
each triangle's cell and the candidate cells, grouping into patches, the feature test, the
one-ring lists, the side normals, the grid samples' own planes where the field is locally linear
(isoscope.core.sharp.planes), corners in empty cells, fans and the test that none folds, edge flips, the
feature vertices' normals and the crisp normals for drawing (core.sharp.normals.crisp_normals; the
drawn mesh is uploaded).
`sharpen(..., solver=SharpExtractor(ex).patch_points)` is the numpy reference with pass 1
swapped in; it gives the same mesh (tests/test_sharp_features.py), except where a decision rests on
a value within rounding of its threshold, which the GPU's double arithmetic can take the other way
(thresholds that whole-number data meets exactly carry a margin: third_side_bound).  Pass 1 takes the
positions `sharpen` gives it (uploading only the vertices its lists name), not the mesh buffer: `sharpen`
may have moved vertices next to a kink.  Pass 0 reads the extractor's vertex buffer by index, so
a mesh too large for one storage block of the GL (over ~4 M vertices in 128 MiB) leaves it to
numpy; so does pass 1 if its lists would not fit.  A GPU candidate-cell pass
was tried and dropped: on llvmpipe it cost more than numpy's read-back and test (git log).
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..core.layout import GROUP_SIZE, VERTEX_BYTES, VERTEX_FLOATS, StorageBlock
from ..core.sharp.cells import bend_cos
from ..core.sharp.patches import MAX_PATCH_VERTICES
from ..core.sharp.points import CLUSTER_ANGLE, LINE_MARGIN, third_side_bound
from ..core.sharp.points import patch_points as numpy_patch_points
from ..core.sharp.qef import JACOBI_SWEEPS, SINGULAR_CUTOFF
from ..errors import InputError
from .buffers import GrowableBuffers
from .mesh import GpuMesh
from .programs import compute_program, dispatch_groups, set_uniforms
from .resident import ResidentVolume, resident_of

RING_STEP = 48
"""Ring lists' capacity in the shader is their width rounded up to this (one program per capacity).

One capacity covers every ring seen (widths ~20-30 on noise, boxes), so a process compiles emc_solve
once.  Not smaller: llvmpipe keeps private arrays of up to ~32 entries in registers, and then takes
~16-18 s to compile the shader (capacity 32) against ~2 s from 40 on, where they live in scratch
memory; the solve runs as fast either way (noise 128: 0.25 s at 32, 0.23 s at 48).  Timed with
MESA_SHADER_CACHE_DISABLE=true: Mesa's disk cache hides the compile after a machine's first run."""


def _double(value) -> str:
    return f"{float(value)!r}lf"


class SharpExtractor:
    """Runs the Extended-MC passes on meshes of one resident volume; keeps its scratch buffers.

    `volume`: a ResidentVolume, or an extractor, whose resident volume it reads and whose last mesh
    `may_bend` then takes by default."""

    def __init__(self, volume: ResidentVolume):
        self.volume = resident_of(volume)
        self.extractor = None if volume is self.volume else volume  # only for may_bend's default mesh
        self.ctx = self.volume.ctx
        self._defines = {**self.volume.defines, "JACOBI_SWEEPS": JACOBI_SWEEPS,
                         "SINGULAR_CUTOFF_SQ": _double(SINGULAR_CUTOFF ** 2),
                         "CLUSTER_COS": _double(np.cos(np.radians(CLUSTER_ANGLE))),
                         "LINE_MARGIN": _double(LINE_MARGIN), "MAX_PATCH_VERTICES": MAX_PATCH_VERTICES}
        self._buffers = GrowableBuffers(self.ctx)
        self._block_bytes = self.volume.plan.limits.max_storage_block_bytes

    def _fits(self, *sizes: int) -> bool:
        """Whether storage blocks of these byte sizes can be bound (GL_MAX_SHADER_STORAGE_BLOCK_SIZE)."""
        return max(sizes) <= self._block_bytes

    def _program(self, name: str, **defines) -> moderngl.ComputeShader:
        return compute_program(self.ctx, f"{name}.comp", {**self._defines, **defines})

    def _upload(self, name: str, array: np.ndarray) -> moderngl.Buffer:
        return self._buffers[name].write(np.ascontiguousarray(array).tobytes())

    def may_bend(self, angle: float, mesh: GpuMesh | None = None, each: bool = False):
        """Pass 0 (emc_flags.comp) on `mesh` (default: the extractor's): whether some vertex may sit in a
        feature cell (core.sharp.cells.vertex_may_bend).  False: `sharpen` would return the plain mesh
        as it is, so nothing need be read back.  `each`: the per-vertex flags instead (for tests).
        None: the mesh is too large for one storage block, so the pass did not run (ask numpy)."""
        if mesh is None:
            if self.extractor is None:
                raise InputError("may_bend needs the mesh: this SharpExtractor was made from a resident volume")
            mesh = self.extractor.mesh
        volume = self.volume
        n = mesh.n_vertices
        if n == 0:
            return np.zeros(0, bool) if each else False
        if not self._fits(n * VERTEX_BYTES, 4 * (1 + n) if each else 4):
            return None
        program = self._program("emc_flags", **({"FLAG_EACH": 1} if each else {}))
        set_uniforms(program, **volume.grid_uniforms, u_sign=volume.sign, u_vertex_count=n,
                     u_cos_half=float(bend_cos(angle)))
        volume.bind()
        flags = self._upload("flags", np.zeros(1 + n if each else 1, np.uint32))
        flags.bind_to_storage_buffer(StorageBlock.FLAGS)
        mesh.vertex_buffer.bind_to_storage_buffer(StorageBlock.MESH_VERTICES, size=n * VERTEX_BYTES)
        dispatch_groups(program, -(-n // GROUP_SIZE))
        self.ctx.memory_barrier()
        if each:
            return np.frombuffer(flags.read(size=4 * (1 + n)), np.uint32)[1:] > 0
        return bool(np.frombuffer(flags.read(size=4), np.uint32)[0])

    def patch_points(self, verts, plane_normals, members, ring_members, lower, upper, spacing, cos_angle):
        """isoscope.core.sharp.features.patch_points on the GPU for meshes of the resident volume.  The planes'
        normals are made from the volume at `verts` (so `plane_normals` is not read); only the vertices
        the lists name go up, renumbered (sharpen may have moved some next to a kink: sharp_planes)."""
        volume = self.volume
        n_patches = len(members)
        if n_patches == 0:
            return np.zeros((0, 3)), np.zeros(0, bool), np.zeros((0, 3))
        listed = np.zeros(len(verts), bool)  # (a mask, not np.unique: its hash table took ~85 ms on the MNI T1)
        listed[members[members >= 0]] = listed[ring_members[ring_members >= 0]] = True
        used = np.flatnonzero(listed)
        new_index = np.full(len(verts), -1, np.int32)
        new_index[used] = np.arange(len(used), dtype=np.int32)
        ring_width = ring_members.shape[1]
        if not self._fits(len(used) * VERTEX_BYTES, 4 * members.size, 4 * ring_members.size, 64 * n_patches):
            return numpy_patch_points(verts, plane_normals, members, ring_members, lower, upper, spacing, cos_angle)
        records = np.zeros((len(used), VERTEX_FLOATS), np.float32)  # the vertex record's layout, positions only
        records[:, :3] = verts[used]

        def renumbered(lists):  # ascending lists stay ascending: -1 padding stays last
            return np.where(lists >= 0, new_index[np.maximum(lists, 0)], -1).astype(np.int32)
        cells = np.rint(lower / np.asarray(spacing, np.float64)).astype(np.int32)
        program = self._program("emc_solve", RING_CAPACITY=-(-max(ring_width, MAX_PATCH_VERTICES) // RING_STEP)
                                * RING_STEP)
        set_uniforms(program, **volume.grid_uniforms, u_sign=volume.sign, u_patch_count=n_patches,
                     u_ring_width=ring_width)
        program["u_spacing_d"].value = tuple(float(s) for s in spacing)
        program["u_out_of_plane"].value = third_side_bound(cos_angle)
        volume.bind()
        self._upload("members", renumbered(members)).bind_to_storage_buffer(StorageBlock.PATCH_MEMBERS)
        self._upload("ring", renumbered(ring_members)).bind_to_storage_buffer(StorageBlock.RING_MEMBERS)
        self._upload("cells", cells).bind_to_storage_buffer(StorageBlock.CELLS)
        out = self._upload("points", np.zeros(8 * n_patches, np.float64))
        out.bind_to_storage_buffer(StorageBlock.POINTS)
        self._upload("vertices", records).bind_to_storage_buffer(StorageBlock.MESH_VERTICES)
        dispatch_groups(program, -(-n_patches // GROUP_SIZE))
        self.ctx.memory_barrier()
        result = np.frombuffer(out.read(size=64 * n_patches), np.float64).reshape(-1, 8)
        corner = np.where(result[:, 7:8] > 0, result[:, 4:7], np.nan)
        return result[:, :3].copy(), result[:, 3] > 0, corner

    def release(self) -> None:
        self._buffers.release()
