"""Signed-distance fields of boxes, their true edges and faces, and point-to-mesh distances (for the tests)."""
from __future__ import annotations

import numpy as np


def rotation(a, b, c):
    """Rotation about axis 0 by a, then 1 by b, then 2 by c (radians)."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ ry @ rx


class Box:
    def __init__(self, center, half, rot=None):
        self.center, self.half = np.asarray(center, float), np.asarray(half, float)
        self.rot = np.eye(3) if rot is None else np.asarray(rot)

    def sdf(self, p):
        q = np.abs((p - self.center) @ self.rot) - self.half
        return np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(axis=-1), 0)

    def corners(self):
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        return (signs * self.half) @ self.rot.T + self.center

    def edge_points(self, step=0.05):
        """Points along the 12 edges, `step` apart."""
        c = self.corners()
        out = []
        for i in range(8):
            for bit in (1, 2, 4):
                if not i & bit:
                    t = np.linspace(0, 1, int(np.linalg.norm(c[i | bit] - c[i]) / step) + 2)[:, None]
                    out.append(c[i] + t * (c[i | bit] - c[i]))
        return np.concatenate(out)

    def face_points(self, step=0.25):
        """Points on the six faces, about `step` apart."""
        out = []
        for axis in range(3):
            u, v = [a for a in range(3) if a != axis]
            su = np.linspace(-self.half[u], self.half[u], int(2 * self.half[u] / step) + 2)
            sv = np.linspace(-self.half[v], self.half[v], int(2 * self.half[v] / step) + 2)
            gu, gv = np.meshgrid(su, sv, indexing="ij")
            for side in (-1, 1):
                local = np.zeros((gu.size, 3))
                local[:, u], local[:, v], local[:, axis] = gu.ravel(), gv.ravel(), side * self.half[axis]
                out.append(local @ self.rot.T + self.center)
        return np.concatenate(out)


def grid_points(n):
    return np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), axis=-1).astype(float)


def point_triangle_distances(points, tri):
    """Distance from each point (N, 3) to each triangle (M, 3, 3): (N, M), by the closest point (Ericson).
    With triangles per point (N, M, 3, 3): each point to its own M triangles."""
    p = points[:, None, :]
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp, cp = p - b, p - c
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) < 1e-30, 1e-30, denom)
    v, w = vb / denom, vc / denom
    inside = (va >= 0) & (vb >= 0) & (vc >= 0)
    best = np.where(inside, np.linalg.norm(p - (a + v[..., None] * ab + w[..., None] * ac), axis=-1), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):  # outside the face: the nearest point on its edges
        d = e - s
        t = np.clip(((p - s) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-30), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (s + t[..., None] * d), axis=-1))
    return best


def distance_to_mesh(points, verts, faces, near=32):
    """The distance from each point to the mesh, over the `near` triangles with the nearest centroids
    (exact for meshes of small triangles, as marching cubes makes)."""
    from scipy.spatial import cKDTree
    tri = verts[faces].astype(np.float64)
    _, nearest = cKDTree(tri.mean(axis=1)).query(points, k=min(near, len(tri)))
    nearest = nearest.reshape(len(points), -1)
    batch = 2048   # points at a time: (batch, near, 3) temporaries of a few MB
    return np.concatenate([point_triangle_distances(points[i:i + batch], tri[nearest[i:i + batch]]).min(axis=1)
                           for i in range(0, len(points), batch)]) if len(points) else np.zeros(0)
