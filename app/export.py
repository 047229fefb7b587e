"""Write a triangle mesh to disk: binary little-endian PLY.

PLY is what MeshLab, Blender, ParaView and trimesh all open; binary keeps a
multi-million-triangle mesh to a quick write and a compact file.
Layout: per vertex float32 x y z nx ny nz; per face a uchar count (3) and
three int32 vertex indices.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

_VERTEX_DTYPE = np.dtype([("position", "<f4", 3), ("normal", "<f4", 3)])
_FACE_DTYPE = np.dtype([("count", "u1"), ("indices", "<i4", 3)])  # packed: 13 bytes a face


def write_ply(path, verts, faces, normals, comment: str = "written by isoscope") -> Path:
    """Write `verts` (N,3), `faces` (M,3) and `normals` (N,3) to `path`; returns the path."""
    verts = np.asarray(verts, np.float32).reshape(-1, 3)
    normals = np.asarray(normals, np.float32).reshape(-1, 3)
    faces = np.asarray(faces).reshape(-1, 3)
    if len(normals) != len(verts):
        raise ValueError(f"{len(verts)} vertices but {len(normals)} normals; pass one normal per vertex")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(verts)):
        raise ValueError(f"face indices must lie in [0, {len(verts)}); got {faces.min()}..{faces.max()}")

    vertex_records = np.empty(len(verts), _VERTEX_DTYPE)
    vertex_records["position"] = verts
    vertex_records["normal"] = normals
    face_records = np.empty(len(faces), _FACE_DTYPE)
    face_records["count"] = 3
    face_records["indices"] = faces

    header = "\n".join([
        "ply",
        "format binary_little_endian 1.0",
        f"comment {comment}",
        f"element vertex {len(verts)}",
        *(f"property float {name}" for name in ("x", "y", "z", "nx", "ny", "nz")),
        f"element face {len(faces)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]) + "\n"
    path = Path(path)
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(vertex_records.tobytes())
        out.write(face_records.tobytes())
    return path
