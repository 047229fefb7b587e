"""Several meshes as one: their arrays end to end, each one's faces moved past the vertices before it."""
from __future__ import annotations

import numpy as np

__all__ = ["joined"]


def joined(parts, faces_dtype=np.int32) -> tuple[np.ndarray, ...]:
    """`parts`: one or more meshes, each (verts, faces, *per-vertex arrays) with the same number of arrays.
    Returns the same arrays joined, the faces (as `faces_dtype`) numbering the joined vertices; every other
    array keeps its type (numpy's rules where the parts' types differ)."""
    parts = list(parts)
    if not parts:
        raise ValueError("joined needs at least one mesh")
    starts = np.cumsum([0] + [len(part[0]) for part in parts[:-1]])
    if len(parts[0][0]) and starts[-1] + len(parts[-1][0]) > np.iinfo(faces_dtype).max:
        raise ValueError(f"{starts[-1] + len(parts[-1][0]):,} vertices do not fit {np.dtype(faces_dtype)} faces")
    faces = np.concatenate([np.asarray(part[1], np.int64).reshape(-1, 3) + start
                            for part, start in zip(parts, starts)]).astype(faces_dtype, copy=False)
    others = [np.concatenate([part[n] for part in parts]) for n in range(len(parts[0])) if n != 1]
    return (others[0], faces, *others[1:])
