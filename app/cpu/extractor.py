"""The CPU extractor: a volume kept in memory and re-extracted at any level, with the GPU Extractor's methods.

`CpuExtractor` is what the viewer and the API use where there is no OpenGL 4.3 context (macOS's 4.1,
no GL at all).  It answers like `isoscope.gpu.cubes.Extractor`: ``extract(level)`` returns the counts,
``read_mesh()`` the arrays as `isoscope.api.outward_marching_cubes` returns them (isoscope's own mesh,
values the level; `isoscope.marching_cubes` follows scikit-image's winding and values instead),
``value_range``, ``shape``, ``spacing``, ``level``, ``release()`` and the context manager.  The mesh is
the GPU's, vertex for vertex and triangle for triangle (the order of `isoscope.cpu.cubes`).
"""
from __future__ import annotations

import numpy as np

from .. import validation
from ..core.case_table import CaseTable, montani_table
from ..core.trilinear_table import topology_problem
from ..errors import InputError, ReleasedError
from .cubes import marching_cubes_reference

__all__ = ["CpuExtractor"]


class CpuExtractor:
    """Keeps one volume in memory (as given: its own type and memory order) and extracts its marching-cubes
    isosurface at any level.

    Parameters
    ----------
    volume : (X, Y, Z) array_like or validation.CheckedVolume
        The samples; checked once (a CheckedVolume with its range is not scanned again).
    spacing : three floats, default (1, 1, 1)
        The distance between samples along each axis; vertices are in these units.
    gradient_direction : {"descent", "ascent"}, default "descent"
        As for `isoscope.marching_cubes`.
    backend : {"cpu", "numpy"}, default "cpu"
        "cpu": the compiled kernels (`isoscope.cpu.compiled`: a new level reads only the words of 32
        samples it cuts); "numpy": the reference extractor (`isoscope.cpu.cubes`).  The same mesh.
    table : CaseTable, optional
        The case table (default: the generated Montani table isoscope.marching_cubes uses).
    topology : {"montani", "trilinear"}, default "montani"
        As for `isoscope.marching_cubes` ("trilinear": the interpolant's topology, `isoscope.cpu.trilinear`;
        not with `table`).

    Examples
    --------
    >>> import numpy as np
    >>> x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    >>> ball = (1 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    >>> with CpuExtractor(ball) as extractor:
    ...     counts = extractor.extract(0.5)
    ...     verts, faces, normals, values = extractor.read_mesh()
    >>> counts == (len(verts), len(faces))
    True
    """

    def __init__(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent", backend: str = "cpu",
                 table: CaseTable | None = None, topology: str = "montani"):
        if backend not in ("cpu", "numpy"):
            raise InputError(f"backend {backend!r} is not one of ('cpu', 'numpy')")
        if topology_problem(topology):
            raise InputError(topology_problem(topology))
        if topology == "trilinear" and table is not None:
            raise InputError("topology='trilinear' has its own table: give no table with it")
        self.topology = topology
        checked = validation.check_volume(volume)
        self.spacing = validation.as_spacing(spacing, checked.samples.shape)
        self.descent = validation.as_gradient_direction(gradient_direction)
        self.gradient_direction = gradient_direction
        self.value_range = checked.value_range
        self.shape = tuple(int(n) for n in checked.samples.shape)
        self.backend = backend
        self.table = table or montani_table()
        self._checked = checked
        self._compiled = None
        if backend == "cpu" and topology == "trilinear":
            from .compiled_trilinear import CompiledTrilinear
            self._compiled = CompiledTrilinear(checked.samples, self.spacing, self.descent, reuse_outputs=True,
                                               value_range=self.value_range)
        elif backend == "cpu":
            from .compiled import CompiledCubes  # numba loads on first use: `import isoscope` stays light
            # the samples read where they lie, in their own type and order: no float32 copy of the volume
            self._compiled = CompiledCubes(checked.samples, self.spacing, self.descent, self.table,
                                           reuse_outputs=True, value_range=self.value_range)
        self._mesh = None
        self._field = None
        self.level: float | None = None
        self.n_vertices = self.n_triangles = 0

    @property
    def field(self) -> np.ndarray | None:
        """The samples as float32 in C order (for smoothing and sharp features), made on first use; None after
        release.  The compiled extractor itself reads the volume as it was given."""
        if self._checked is None:
            return None
        if self._field is None:
            self._field = np.ascontiguousarray(self._checked.data, dtype=np.float32)
        return self._field

    def extract(self, level: float) -> tuple[int, int]:
        """Extract the surface at `level` (within value_range); returns (vertices, triangles)."""
        if self._checked is None:
            raise ReleasedError("this CpuExtractor was released (release(), or its with block ended): its volume "
                                "is gone; make a new one")
        level = validation.as_level(level, self.value_range)
        self._mesh = self._extract(level)
        self.level = level
        self.n_vertices, self.n_triangles = len(self._mesh[0]), len(self._mesh[1])
        return self.n_vertices, self.n_triangles

    def _extract(self, level: float):
        if self._compiled is not None:
            return self._compiled.extract(level)
        if self.topology == "trilinear":
            from .trilinear import marching_cubes_trilinear
            return marching_cubes_trilinear(self.field, level, self.spacing, self.descent)
        return marching_cubes_reference(self.field, level, self.spacing, self.descent, self.table)

    @property
    def mesh(self):
        """The last extraction's (verts, faces, normals, values), not copied (the next extract may write
        over them: upload or copy them first); None before the first."""
        return self._mesh

    def read_mesh(self):
        """verts (N, 3) float32, faces (M, 3) int32, normals (N, 3) float32, values (N,) float32 of the
        last extraction, as `isoscope.api.outward_marching_cubes` returns them (copies: the caller may keep
        them)."""
        if self._checked is None:
            raise ReleasedError("this CpuExtractor was released (release(), or its with block ended): its volume "
                                "is gone; make a new one")
        if self._mesh is None:
            raise InputError("nothing extracted yet: call extract(level) first")
        return tuple(part.copy() for part in self._mesh)

    def release(self) -> None:
        """Drop the volume and the mesh; safe to call twice."""
        self._checked = self._field = None
        self._compiled = None
        self._mesh = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
