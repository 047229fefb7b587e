"""Skirts: the strips that hide the cracks where a mesh at full resolution meets a coarser one.

Two meshes of one level set made at two resolutions end at the same brick face along two different curves
(each its own approximation of where the surface crosses the face), so a crack opens between them.  A
skirt folds each mesh's rim edge on that face down into the object (against its triangle's winding normal)
by about one coarse cell: whichever mesh lies outside the other there, its skirt closes the gap as seen
from outside.  The fold keeps the triangle's orientation (the rim edge taken backwards, as a neighbour
across it would), so the side of the skirt seen through the crack is its front side.  Lengyel's transition
cells (Transvoxel) join the levels exactly; skirts are far simpler, need no knowledge of the other level's
mesh, and cost a strip of triangles per seam (Ulrich's chunked LOD, the same trade).

Pure numpy, no GL: `rim_of` keeps a mesh's open edges (small: they lie in the faces of its box), `skirt`
makes the strips of the ones asked for.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Rim:
    """Open edges of a mesh, each as its triangle orients it: `ends` (E, 2, 3) positions, `normals` (E, 2, 3)
    and `values` (E, 2) at the ends, `down` (E, 3) the unit direction into the object (against the winding
    normal), and `triangle` (E,) the index of the triangle the edge is on."""
    ends: np.ndarray
    normals: np.ndarray
    values: np.ndarray
    down: np.ndarray
    triangle: np.ndarray

    def __len__(self) -> int:
        return len(self.ends)

    def subset(self, keep) -> Rim:
        """The edges where `keep` (a mask or indices)."""
        return Rim(self.ends[keep], self.normals[keep], self.values[keep], self.down[keep], self.triangle[keep])


def edge_keys(faces) -> np.ndarray:
    """(3 M,) int64: a number for the undirected edge of each directed edge `faces[t, c] -> faces[t, (c + 1) % 3]`,
    at 3 t + c; two triangles sharing an edge have the same number there.  `faces`: (M, 3), M > 0."""
    start, stop = faces, np.roll(faces, -1, axis=1)
    return (np.minimum(start, stop) * (int(faces.max()) + 1) + np.maximum(start, stop)).ravel()


def edges_used_once(faces) -> np.ndarray:
    """(triangle, corner) of each directed edge `faces[t, c] -> faces[t, (c + 1) % 3]` that no other triangle
    shares (an edge of the mesh's border, or of a cut)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if not len(faces):
        return np.zeros((0, 2), dtype=np.int64)
    _, inverse, counts = np.unique(edge_keys(faces), return_inverse=True, return_counts=True)
    once = np.flatnonzero(counts[inverse.ravel()] == 1)
    return np.stack(np.divmod(once, 3), axis=1)


def rim_of(verts, faces, normals, values, edges=None) -> Rim:
    """The mesh's open edges (or the (triangle, corner) `edges` given) as a Rim."""
    verts, faces = np.asarray(verts, dtype=np.float32), np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    edges = edges_used_once(faces) if edges is None else np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    triangle, corner = edges[:, 0], edges[:, 1]
    ids = np.stack([faces[triangle, corner], faces[triangle, (corner + 1) % 3]], axis=1)   # (E, 2)
    corners = verts[faces[triangle]].astype(np.float64)                                     # (E, 3, 3)
    winding = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(winding, axis=1, keepdims=True)
    down = -winding / np.where(length > 0, length, 1.0)
    return Rim(verts[ids], np.asarray(normals, np.float32)[ids], np.asarray(values, np.float32)[ids],
               down.astype(np.float32), triangle)


def skirt(rim: Rim, depth: float):
    """verts, faces, normals, values of a strip `depth` deep under each edge of `rim`: two triangles an edge,
    (b, a, a') and (b, a', b') for the edge a -> b and a' = a + depth * down (four vertices of their own: the
    strips of neighbouring edges overlap, they need not join).  The normals are the rim's: lit as the
    surface beside it."""
    n = len(rim)
    a, b = rim.ends[:, 0], rim.ends[:, 1]
    drop = (float(depth) * rim.down)
    verts = np.stack([a, b, a + drop, b + drop], axis=1).reshape(-1, 3).astype(np.float32)
    normals = np.concatenate([rim.normals, rim.normals], axis=1).reshape(-1, 3)
    values = np.concatenate([rim.values, rim.values], axis=1).reshape(-1)
    first = 4 * np.arange(n, dtype=np.int32)[:, None]
    faces = (first + np.array([[1, 0, 2], [1, 2, 3]], dtype=np.int32).reshape(1, 6)).reshape(-1, 3)
    return verts, faces.astype(np.int32), normals.astype(np.float32), values.astype(np.float32)
