"""Fewer triangles for export: quadric edge-collapse decimation (fast-simplification), and how far
the result strays from the level set it came from.

fast-simplification is a maintained wrapper of Fast-Quadric-Mesh-Simplification (the
algorithm of Garland and Heckbert's quadric error metrics); open borders (the
volume's edge cutting the surface) are kept fixed, so a closed surface stays closed
and an open one keeps its outline.  Normals of the decimated mesh are the area-weighted
averages of its faces' normals, pointing the way its triangles wind (outwards).
"""
from __future__ import annotations

import numpy as np

from ..core.interpolate import trilinear_value
from ..errors import InputError


def open_edges(faces: np.ndarray) -> int:
    """Edges used by one triangle only: 0 for a closed surface."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.count_nonzero(counts == 1))


def vertex_normals(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, unit length, the way the triangles wind."""
    corners = verts[faces]
    face_normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # length = 2 area
    normals = np.zeros_like(verts)
    for k in range(3):
        np.add.at(normals, faces[:, k], face_normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return (normals / np.where(length > 0, length, 1)).astype(np.float32)


def check_fraction(fraction: float) -> float:
    """`fraction` (of the triangles to keep) as a float, if it lies in (0, 1]; else an InputError naming --decimate."""
    if not 0 < fraction <= 1:
        raise InputError(f"--decimate {fraction:g} must be a fraction of the triangles to keep, in (0, 1]")
    return float(fraction)


def decimate(verts, faces, fraction: float):
    """(verts, faces, normals) with about `fraction` of the triangles, 0 < fraction <= 1."""
    check_fraction(fraction)
    verts, faces = np.asarray(verts, np.float32), np.asarray(faces, np.int64)
    if fraction == 1 or len(faces) < 4:
        return verts, faces.astype(np.int32), vertex_normals(verts, faces)
    import fast_simplification
    target = max(4, int(round(fraction * len(faces))))
    out_verts, out_faces = fast_simplification.simplify(verts.astype(np.float64), faces, target_count=target,
                                                        preserve_border=True)
    out_verts = out_verts.astype(np.float32)
    out_faces = out_faces.astype(np.int32)
    return out_verts, out_faces, vertex_normals(out_verts, out_faces)


def distance_off_level_set(field: np.ndarray, spacing, level: float, verts: np.ndarray) -> np.ndarray:
    """Each vertex's distance (world units) from the level set: |F - level| / |grad F|, with F the
    trilinear interpolant of the samples and its gradient by central differences half a voxel wide."""
    spacing = np.asarray(spacing, np.float64)
    points = np.asarray(verts, np.float64) / spacing
    off = np.abs(trilinear_value(field, points) - level)
    gradient = np.empty((len(points), 3))
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = 0.5
        ahead, behind = trilinear_value(field, points + step), trilinear_value(field, points - step)
        gradient[:, axis] = (ahead - behind) / spacing[axis]
    return off / np.maximum(np.linalg.norm(gradient, axis=1), 1e-12)
