"""The GPU marching-cubes extractor: a volume resident in a 3-D texture, re-extracted per level.

The cubes' cell kind (`CUBES`) and `Extractor`, which uploads a volume (a `ResidentVolume` of its
own, resident.py) and extracts it at any level (extraction.py: the passes, as in NVIDIA's CUDA
sample, but producing an indexed mesh and sized from the scans, so nothing is ever dropped):

0. ``mc_row_range``, ``mc_brick_range``  once per volume (resident.py): the value range of each
   brick (8 x 8 rows x 32 samples, plus the halo its cells reach), for skipping
1-8. ``mc_bricks``, ``mc_signs``, ``mc_classify``, ``mc_brick_sums``, the scans,
   ``mc_word_offsets``, ``mc_triangles``, ``mc_vertices`` (extraction.py says what each does)

Scratch: 16 bytes per 32-sample word plus 24 per brick (about 0.5 byte per voxel;
0.75 for a moment while the brick ranges are measured), and 4 bytes per vertex for the jobs
(shaders/vertex_jobs.glsl says why they have a buffer of their own).
"""
from __future__ import annotations

import moderngl

from ..core.case_table import CaseTable, montani_table
from ..core.layout import WORD_BITS
from ..errors import InputError
from .cell_kind import CellKind
from .extraction import SurfaceExtractor
from .limits import GPULimitError, GpuLimits
from .resident import ResidentVolume

__all__ = ["CUBES", "Extractor", "GPULimitError"]

CUBES = CellKind("cubes", classify="mc_classify", brick_sums="mc_brick_sums", word_offsets="mc_word_offsets",
                 triangles="mc_triangles", vertices="mc_vertices", job_components=1, count_components=1,
                 table=montani_table, job_coordinates=True)
"""Marching cubes: a job is one uint (word id, axis, bit, or the sample's coordinates: mc_jobs.glsl),
a word's counts one uint (mc_cells.glsl)."""


class Extractor(SurfaceExtractor):
    """Keeps one volume on the GPU and extracts its marching-cubes isosurface at any level.

    Parameters
    ----------
    volume : (X, Y, Z) array_like or validation.CheckedVolume
        The samples; a CheckedVolume is taken without scanning it again.  8- and 16-bit integers stay
        integers on the GPU; anything else becomes float32.
    spacing : three floats, default (1, 1, 1)
        The distance between samples along each axis; vertices are in these units.
    gradient_direction : {"descent", "ascent"}, default "descent"
        "descent" when the object is where values are above the level (a density, a CT), "ascent"
        where they are below (a signed distance field): normals point out of the object.
    ctx : moderngl.Context, optional
        The GL context (default: the current one, else a standalone EGL context).
    table : CaseTable, optional
        The case table (default: the generated Montani table isoscope.marching_cubes uses).
    limits : GpuLimits, optional
        Overrides the GL implementation's limits (tests lower them to reach the refusals).

    Attributes
    ----------
    resident : ResidentVolume
        The volume on the GPU, its bricks' value ranges and grid uniforms; this extractor's own.
    value_range : (float, float)
        The volume's smallest and largest finite values.
    mesh : GpuMesh
        A view of the last extraction's vertex and index buffers, for drawing without a copy.

    Raises
    ------
    GPULimitError
        When the volume or a mesh does not fit this GPU's limits (checked before allocating).

    Notes
    -----
    `extract(level)` runs the passes and returns the counts (the mesh stays on the GPU);
    `read_mesh()` reads it back as isoscope.api.outward_marching_cubes returns it; `reload(volume)` replaces
    the volume in place where it `fits`.  Construction is all or nothing: every size limit is
    checked before anything is allocated, and whatever was allocated is released if a later step
    fails.  `release()` (or leaving a ``with`` block) frees every GL object it made, its resident
    volume too; a `TetraExtractor` or `Smoother` made on it is released first.  The mesh equals
    ``outward_marching_cubes(volume, level, backend="cpu")`` bit for bit in faces.

    Examples
    --------
    >>> import numpy as np
    >>> from isoscope import Extractor
    >>> from isoscope.api import outward_marching_cubes
    >>> x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    >>> ball = (1 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    >>> with Extractor(ball) as extractor:
    ...     counts = extractor.extract(0.5)
    ...     verts, faces, normals, values = extractor.read_mesh()
    ...     second = extractor.extract(0.25)           # a new level: the volume stays on the GPU
    >>> counts == (len(verts), len(faces))
    True
    >>> second[1] > counts[1]                           # the larger sphere has more triangles
    True
    >>> bool(np.array_equal(faces, outward_marching_cubes(ball, 0.5, backend="cpu")[1]))
    True
    """

    KIND = CUBES
    """The cells it marches (trilinear.py's subclass marches the trilinear topology's)."""
    WORD_TRIANGLES = 255
    """The most triangles a word's counts hold (8 bits: mc_cells.glsl)."""

    def __init__(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                 ctx: moderngl.Context | None = None, table: CaseTable | None = None,
                 limits: GpuLimits | None = None):
        table = table or self.KIND.table()
        if WORD_BITS * table.max_triangles > self.WORD_TRIANGLES:  # the bits of a word's triangle count
            raise InputError(f"a case table with up to {table.max_triangles} triangles per cell does not fit "
                             f"the per-word counts; at most {self.WORD_TRIANGLES // WORD_BITS} can")
        resident = ResidentVolume(volume, spacing, gradient_direction, ctx=ctx, limits=limits)
        try:
            super().__init__(resident, self.KIND, table)
        except BaseException:
            resident.release()
            raise

    def fits(self, volume) -> bool:
        """Whether `reload` can take `volume` (an array or a CheckedVolume): the same shape, and samples
        the volume image holds in the same format."""
        return self.resident.fits(volume)

    def reload(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent") -> None:
        """Take a new volume of the same shape and sample format (`fits`) into this extractor's GL objects
        (ResidentVolume.reload: nothing is allocated; on a 256^3 float32 volume new storage was 26 of the
        one-shot call's ~90 ms, and the mesh buffers grew from nothing again).  The last mesh is dropped.
        A volume that does not fit raises ValueError and changes nothing."""
        self.resident.reload(volume, spacing, gradient_direction)
        self.n_vertices = self.n_triangles = self.active_bricks = 0
        self.level = None

    def scratch_bytes(self) -> int:
        """GPU memory beyond the volume image and the mesh buffers: the extractor's and the brick ranges."""
        return super().scratch_bytes() + self.resident.scratch_bytes()

    def gpu_bytes(self) -> int:
        """All the GL memory this extractor holds: the volume image, scratch_bytes and the mesh buffers."""
        if self.resident.texture is None:
            return 0
        return self.resident.image_bytes() + super().gpu_bytes() + self.resident.scratch_bytes()

    def release(self) -> None:
        """Free every GL object this extractor made, its resident volume included; safe to call twice."""
        super().release()
        self.resident.release()
