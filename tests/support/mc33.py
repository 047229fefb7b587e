"""MC33's 33 configurations of one cell (Chernyaev 1995), each a 2x2x2 grid written here by hand, and the cell's
symmetries (test_mc33_configurations says what each grid is and checks it).

Corner ``c`` of the cell sits at ``(c & 1, c >> 1 & 1, c >> 2 & 1)`` (the case table's corner order), level 0.
"""
from __future__ import annotations

import numpy as np

from isoscope.core.case_table import CORNER_OFFSETS, FACE_CORNERS

# name: (the eight corner values, (pieces, Euler characteristic) of the configuration's surface in the cell)
MC33 = {
    "0": ([-6, -2, -1, -5, -1, -2, -4, -1], (0, 0)),
    "1": ([3, -4, -2, -3, -2, -6, -2, -1], (1, 1)),
    "2": ([1, 6, -1, -3, -8, -2, -1, -1], (1, 1)),
    "3.1": ([-4, 5, 1, -3, -4, -7, -1, -1], (2, 2)),
    "3.2": ([-3, 6, 1, -1, -5, -8, -4, -2], (1, 1)),
    "4.1.1": ([-7, -1, -4, 5, 1, -1, -2, -3], (2, 2)),
    "4.1.2": ([-9, -1, -1, 7, 8, -1, -4, -1], (1, 0)),
    "5": ([4, 1, 4, -4, -2, -1, -2, -2], (1, 1)),
    "6.1.1": ([4, -1, -5, 1, 2, -3, -5, -5], (2, 2)),
    "6.1.2": ([1, -3, -7, 12, 3, -1, -2, -1], (1, 0)),
    "6.2": ([5, -1, -2, 2, 1, -1, -5, -3], (1, 1)),
    "7.1": ([-3, 1, 3, -2, 3, -3, -5, -1], (3, 3)),
    "7.2": ([-3, 4, 1, -1, 1, -2, -5, -1], (2, 2)),
    "7.3": ([-2, 5, 2, -4, 1, -2, -3, -9], (1, 1)),
    "7.4.1": ([-2, 5, 9, -1, 6, -3, -2, -1], (2, 2)),
    "7.4.2": ([-8, 4, 7, -2, 7, -1, -6, -2], (1, 0)),
    "8": ([1, 1, 5, 6, -1, -2, -4, -1], (1, 1)),
    "9": ([2, 1, 1, -4, 8, -1, -5, -7], (1, 1)),
    "10.1.1": ([-4, -3, 3, 1, 3, 3, -3, -3], (2, 2)),
    "10.1.2": ([-10, -5, 8, 1, 1, 9, -1, -2], (1, 0)),
    "10.2": ([-4, -4, 1, 2, 2, 3, -3, -1], (1, 1)),
    "11": ([1, 9, -1, 3, 6, -2, -4, -4], (1, 1)),
    "12.1.1": ([-4, 5, 2, 5, 2, -5, -2, -1], (2, 2)),
    "12.1.2": ([-6, 2, 1, 5, 8, -3, -5, -2], (1, 0)),
    "12.2": ([-7, 8, 1, 3, 1, -1, -4, -6], (1, 1)),
    "12.3": ([-6, 4, 3, 1, 4, -8, -1, -1], (1, 1)),
    "13.1": ([1, -8, -3, 2, -2, 1, 3, -7], (4, 4)),
    "13.2": ([1, -4, -3, 1, -3, 3, 6, -4], (3, 3)),
    "13.3": ([1, -9, -4, 2, -7, 3, 3, -1], (2, 2)),
    "13.4": ([1, -4, -1, 9, -3, 8, 1, -6], (1, 1)),
    "13.5.1": ([1, -7, -6, 3, -1, 4, 3, -1], (3, 3)),
    "13.5.2": ([1, -7, -7, 8, -3, 4, 4, -4], (2, 1)),
    "14": ([1, -7, 1, 7, 1, -1, -1, -7], (1, 1)),
}

# Lorensen's case of each family: (inside corners, ambiguous faces), taken on the side with fewer inside corners
# (cases 11 and 14 are mirror images, so are 12.2 and 12.3: MC33 counts configurations up to rotation only).
CASES = {"0": (0, 0), "1": (1, 0), "2": (2, 0), "3": (2, 1), "4": (2, 0), "5": (3, 0), "6": (3, 1), "7": (3, 3),
         "8": (4, 0), "9": (4, 0), "10": (4, 2), "11": (4, 0), "12": (4, 2), "13": (4, 6), "14": (4, 0)}


def grid(values) -> np.ndarray:
    field = np.zeros((2, 2, 2), np.float32)
    for corner, (i, j, k) in enumerate(CORNER_OFFSETS):
        field[i, j, k] = values[corner]
    return field


def corner_values(field: np.ndarray) -> list[float]:
    return [float(field[i, j, k]) for i, j, k in CORNER_OFFSETS]


def rotations(field: np.ndarray) -> list[np.ndarray]:
    """The 24 rotations of a cell: each face turned to the bottom, then spun four ways about axis 2."""
    bottoms = [field, *(np.rot90(field, k, (0, 2)) for k in (1, 2, 3)), np.rot90(field, 1, (0, 1)),
               np.rot90(field, 3, (0, 1))]
    return [np.rot90(bottom, k, (1, 2)) for bottom in bottoms for k in range(4)]


def symmetries(field: np.ndarray) -> list[np.ndarray]:
    """The cell in its 48 rotations and mirror images, each also with inside and outside swapped (96 grids)."""
    turned = rotations(field) + rotations(field[::-1])
    return [np.ascontiguousarray(sign * t) for t in turned for sign in (1, -1)]


def face_decisions(values) -> tuple[int, ...]:
    """Per face: -1 not ambiguous, 1 its saddle joins the inside corners, 0 the outside ones; asserted no tie."""
    out = []
    for face in FACE_CORNERS:
        a, b, c, d = (values[corner] for corner in face)   # around the face
        if (a >= 0) == (c >= 0) != (b >= 0) == (d >= 0):
            assert a * c != b * d, "a face's saddle at the level"
            out.append(int((a * c - b * d) / (a + c - b - d) >= 0))
        else:
            out.append(-1)
    return tuple(out)


def configuration_class(field: np.ndarray):
    """The least (inside corners, face decisions) over the cell's rotations and inside/outside swaps: equal for
    two grids exactly when one is the other's configuration turned (the interior aside)."""
    def code(f):
        values = corner_values(f)
        return sum(1 << c for c, v in enumerate(values) if v >= 0), face_decisions(values)
    return min(code(sign * t) for t in rotations(field) for sign in (1, -1))
