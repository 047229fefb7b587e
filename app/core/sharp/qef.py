"""Where tangent planes meet: the quadric error function's solve (Kobbelt et al. 2001).

The least-squares point of a patch's planes, relative to its mass point, through a fixed-step
Jacobi eigen-solve of the 3x3 normal equations (`symmetric_eigen`: the same steps as
shaders/emc_common.glsl), small singular values dropped (`feature_points`).
"""
from __future__ import annotations

import numpy as np

SINGULAR_CUTOFF = 0.1  # singular values below this fraction of the largest are treated as zero
JACOBI_SWEEPS = 6  # cyclic Jacobi sweeps of the 3x3 normal equations: double precision well before then


def symmetric_eigen(m):
    """Eigenvalues (P, 3), descending, and unit eigenvectors (P, 3, 3; column j for value j) of the
    symmetric matrices `m` (P, 3, 3): JACOBI_SWEEPS cyclic Jacobi sweeps (rotations over (0, 1), (0, 2),
    (1, 2)), then a stable sort.  A fixed number of steps, so emc_common.glsl takes the same ones."""
    a = np.array(m, np.float64)
    v = np.broadcast_to(np.eye(3), a.shape).copy()
    with np.errstate(over="ignore"):  # theta overflows for tiny off-diagonals: t = 0, no rotation (as in GLSL)
        for _ in range(JACOBI_SWEEPS):
            for p, q in ((0, 1), (0, 2), (1, 2)):
                apq = a[:, p, q]
                rotate = apq != 0.0
                theta = (a[:, q, q] - a[:, p, p]) / (2.0 * np.where(rotate, apq, 1.0))
                t = np.where(theta >= 0, 1.0, -1.0) / (np.abs(theta) + np.sqrt(theta * theta + 1.0))
                c = np.where(rotate, 1.0 / np.sqrt(t * t + 1.0), 1.0)
                s = np.where(rotate, t * c, 0.0)
                j = np.broadcast_to(np.eye(3), a.shape).copy()
                j[:, p, p], j[:, q, q], j[:, p, q], j[:, q, p] = c, c, s, -s
                a = np.transpose(j, (0, 2, 1)) @ a @ j
                v = v @ j
    values = np.diagonal(a, axis1=1, axis2=2)
    order = np.argsort(-values, axis=1, kind="stable")
    return np.take_along_axis(values, order, axis=1), np.take_along_axis(v, order[:, None, :], axis=2)


def feature_points(positions, normals, valid, lower, upper, mass=None):
    """Where the tangent planes of each patch (P, W, 3) meet: (points, ok, corners, kinds).

    The quadric is solved relative to the mass point through the eigen-decomposition of its normal
    equations (`symmetric_eigen`; the squares of the planes' singular values), singular values under
    SINGULAR_CUTOFF x the largest dropped.  Three kept and the point inside the cell: a corner, that point.
    Otherwise, with two planes' worth (the smallest dropped if need be): an edge, the line where they meet;
    the point on it nearest the mass point, slid along it into the cell.  Not ok: one plane's worth (no
    feature after all) or a line that misses the cell.  `corners`: the rank-3 points, unclamped (nan where
    rank < 3); `kinds`: 3 where the point is such a corner, 2 where it is on a line."""
    w = valid[..., None].astype(np.float64)
    if mass is None:
        mass = (positions * w).sum(axis=1) / np.maximum(w.sum(axis=1), 1.0)  # no plane: rank 0, not ok
    a = normals * w
    b = np.einsum("pvk,pvk->pv", a, positions - mass[:, None, :])
    values, vectors = symmetric_eigen(np.einsum("pvi,pvj->pij", a, a))
    along = np.einsum("pij,pi->pj", vectors, np.einsum("pvi,pv->pi", a, b))  # each eigenvector . A^T b
    keep = values > SINGULAR_CUTOFF ** 2 * values[:, :1]
    rank = keep.sum(axis=1)
    inv = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    corner = mass + np.einsum("pij,pj->pi", vectors, inv * along)
    corner = np.where(rank[:, None] == 3, corner, np.nan)
    inv[:, 2] = 0.0
    x = mass + np.einsum("pij,pj->pi", vectors, inv * along)  # on the line x + t d
    d = vectors[:, :, 2]
    slack = 1e-6 * (upper - lower)
    moving = np.abs(d) > 1e-12
    safe = np.where(moving, d, 1.0)
    t0, t1 = (lower - x) / safe, (upper - x) / safe
    lo = np.where(moving, np.minimum(t0, t1), -np.inf).max(axis=1)
    hi = np.where(moving, np.maximum(t0, t1), np.inf).min(axis=1)
    ok = (rank >= 2) & (lo <= hi) & (moving | ((x >= lower - slack) & (x <= upper + slack))).all(axis=1)
    x = x + np.where(ok, np.clip(0.0, lo, hi), 0.0)[:, None] * d
    inside = (corner >= lower - slack).all(axis=1) & (corner <= upper + slack).all(axis=1)
    x = np.where(inside[:, None], corner, x)
    return np.clip(x, lower, upper), ok | inside, corner, np.where(inside, 3, np.minimum(rank, 2))
