"""The CPU extractors this install has: the compiled (numba) ones where numba is installed, else the numpy references
with the same methods and meshes; and the thread count a small extraction runs on.  The viewer's CPU surface (OpenGL
4.1: viewer/gfx/cpu_surface.py) extracts with them."""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from ..validation import as_gradient_direction, as_level
from .tetra import marching_tetrahedra_reference

SERIAL_SAMPLES = 1 << 20
"""A volume with fewer samples (a drag's preview) is extracted on one thread: its work is a millisecond or
two, and a parallel region then costs more than it saves (MNI T1 at step 4, 50x59x48: 1.6 ms on one
thread, 8.8 ms on two on a 2-core machine with other work running)."""


@contextmanager
def threads_for(n_samples: int):
    """numba's thread count for this thread's next extraction: one below SERIAL_SAMPLES, else as set."""
    try:
        import numba
    except ImportError:   # the numpy extractor: one thread anyway
        yield
        return
    before = numba.get_num_threads()
    if n_samples < SERIAL_SAMPLES:
        numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def tetrahedra_function():
    """The compiled marching tetrahedra where numba is installed, else the numpy one: the same mesh."""
    try:
        from .compiled import marching_tetrahedra_compiled
        return marching_tetrahedra_compiled
    except ImportError:
        return marching_tetrahedra_reference


def cpu_extractor_class():
    """The compiled CPU extractor where it is installed, else the numpy one with the same methods."""
    try:
        from .extractor import CpuExtractor
        return CpuExtractor
    except ImportError:
        return NumpyExtractor


class NumpyExtractor:
    """`CpuExtractor`'s methods over the numpy reference (cpu/cubes.py): the volume kept, each level extracted."""

    def __init__(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent"):
        from ..validation import check_volume
        checked = check_volume(volume)
        self.spacing = tuple(float(s) for s in spacing)
        self.descent = as_gradient_direction(gradient_direction)
        self.value_range = checked.value_range
        self._field = np.ascontiguousarray(checked.data, dtype=np.float32)
        self._mesh = None
        self.level: float | None = None

    @property
    def field(self) -> np.ndarray:
        """The volume being extracted, as kept."""
        return self._field

    def extract(self, level: float) -> tuple[int, int]:
        """Extract the surface at `level` (checked against the value range); (vertices, triangles) of the new mesh."""
        from .cubes import marching_cubes_reference
        level = as_level(level, self.value_range)
        self._mesh = marching_cubes_reference(self._field, level, self.spacing, self.descent)
        self.level = level
        return len(self._mesh[0]), len(self._mesh[1])

    def read_mesh(self):
        """Copies of the last mesh's (verts, faces, normals, values)."""
        return tuple(part.copy() for part in self._mesh)

    def release(self) -> None:
        """Drop the volume and the mesh."""
        self._field = self._mesh = None
