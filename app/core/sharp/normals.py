"""Normals of the sharpened mesh: its feature vertices' (`vertex_normals_from_faces`) and, for
drawing, crisp ones that do not smear shading across an edge (`crisp_normals`).
"""
from __future__ import annotations

import numpy as np


def vertex_normals_from_faces(verts, faces, vertices):
    """Area-weighted mean of the face normals around each of `vertices` (unit length)."""
    wanted = np.zeros(len(verts), bool)
    wanted[vertices] = True
    faces = faces[wanted[faces].any(axis=1)]  # only the faces around them (the same sums, in the same order)
    tri = verts[faces].astype(np.float64)
    area_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    # Per axis one bincount over the corners, corner 0 of every face first: each vertex's sum adds the
    # same numbers in the same order as np.add.at corner by corner would (several times faster).
    corners, weights = faces.T.reshape(-1), np.tile(area_normals, (3, 1))
    picked = np.stack([np.bincount(corners, weights[:, axis], len(verts))[vertices] for axis in range(3)], axis=1)
    return (picked / np.maximum(np.linalg.norm(picked, axis=1, keepdims=True), 1e-30)).astype(np.float32)


def crisp_normals(verts, faces, normals, values, n_plain):
    """A mesh for drawing: every triangle touching a feature vertex (index >= n_plain) gets its own three
    vertices; at its feature corners the mean normal of its other corners (the side it lies on), so
    shading does not smear across the edge; in a mesh with feature vertices, so does every triangle with
    a corner whose normal faces away from it, and such corners get the triangle's own normal.  The rest
    is unchanged (a mesh without feature vertices is returned as it is: the plain mesh)."""
    a, b, c = faces.T  # (per column: numpy reduces short rows slowly)
    flat = (a >= n_plain) | (b >= n_plain) | (c >= n_plain)
    if not flat.any():
        return verts, faces, normals, values
    face_normals = _unit_face_normals(verts, faces)  # once: which faces a corner shades from behind, and how
    flat |= (np.einsum("fck,fk->fc", normals[faces].astype(np.float64), face_normals) < 0.0).any(axis=1)
    rows = faces[flat]
    plain = rows < n_plain
    corner_normals = normals[rows].astype(np.float64)
    weighted = [corner_normals[:, k] * plain[:, k, None] for k in range(3)]
    side = (weighted[0] + weighted[1]) + weighted[2]
    side /= np.maximum(np.sqrt((side[:, 0] * side[:, 0] + side[:, 1] * side[:, 1]) + side[:, 2] * side[:, 2]),
                       1e-30)[:, None]
    corner_normals = np.where(plain[..., None], corner_normals, side[:, None, :])
    # A corner normal more than 90 degrees from its triangle's own normal would shade the triangle from
    # behind (dark specks: on the MNI T1 at 128, thousands of fan triangles that turn 90-107 degrees,
    # which the fold test lets through to keep edges straight, and plain triangles next to them whose
    # corners took the sides' normals): such corners take the triangle's normal.
    face = face_normals[flat]
    behind = np.einsum("fck,fk->fc", corner_normals, face) < 0.0
    corner_normals = np.where(behind[..., None], face[:, None, :], corner_normals)
    start = len(verts)
    out_faces = faces.copy()
    out_faces[flat] = start + np.arange(3 * len(rows)).reshape(-1, 3)
    return (np.concatenate([verts, verts[rows.reshape(-1)]]), out_faces,
            np.concatenate([normals, corner_normals.reshape(-1, 3).astype(np.float32)]),
            np.concatenate([values, values[rows.reshape(-1)]]))


def _unit_face_normals(verts, faces):
    corners = verts[faces].astype(np.float64)
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return face / np.maximum(np.linalg.norm(face, axis=1), 1e-30)[:, None]
