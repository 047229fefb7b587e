"""The numbers of projected smoothing (cpu/smooth.py, its numpy and numba passes, and gpu/smooth.py, its
compute shaders): both backends read them here, so that they move the same vertices the same way."""
from __future__ import annotations

import numpy as np

from .numbers import SMOOTH

UMBRELLA_WEIGHT = 0.5
"""Fraction of the way to the neighbours' average moved per iteration (0.5 damps every mode)."""
NEWTON_STEPS = 4
"""Newton steps per projection (quadratic convergence: 4 reach float precision from < 1 cell)."""
CONVERGED = 0.1
"""Newton stops stepping a vertex once it is within this fraction of ACCEPT x the range of the level
(1e-5 of the range: 0.01 took a third evaluation for ~40% of the vertices, ~10% of an iteration)."""
ACCEPT = 1e-4
"""A projection ending further off its (corrected) level than this fraction of the value range is discarded."""
CORRECTION = 5e-4
"""Largest correction of the level for the interpolant's error, as a fraction of the value range."""
BORDER = 1e-3
"""A coordinate within this many cells of the volume's first or last sample lies on the border."""
MIN_AREA = 1e-5
"""No move shrinks a triangle below this fraction of a voxel face (index units), nor one already
smaller at all (the caps around a tie: 1.3e-5 from marching cubes, 7.6e-6 from tetrahedra)."""
FLOOR_SQUARED = float(np.float32((2 * MIN_AREA) ** 2))
"""MIN_AREA as both backends compare it: against |edge x edge|^2, which is 4 area^2 (float32)."""


def check_iterations(iterations, said: str = "smooth") -> int:
    """`iterations` as an int in SMOOTH's range (0 to a few hundred), or a one-line InputError."""
    return SMOOTH.check(iterations, said)
