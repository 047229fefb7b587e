"""Isocurves of a 2-D image by marching squares: scikit-image's `find_contours`, built the textbook way.

One vertex per sign-changing grid edge, kept in a table keyed by the edge (so a
vertex is shared by the two squares beside its edge), line segments per square
from the sign pattern of its four corners, and curves assembled by walking from
vertex to vertex.  Each vertex starts at most one segment and ends at most one,
so the walk needs no search: open curves start on the image border (or the mask's),
and whatever is left are closed loops.

Ties follow the 3-D extractor's rule: a sample equal to the level counts as above
it (scikit-image counts it as below), and a vertex that would land on such a
sample is moved EDGE_MARGIN (1/256) of its edge off it, so curves never touch a
grid point and no two vertices coincide.  Away from exact ties the vertices are
scikit-image's: the linear interpolation along the edge.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .layout import EDGE_MARGIN

PARAM_OPTIONS = ("low", "high")

# Corners of a square as bits: 1 upper-left (r, c), 2 upper-right (r, c+1), 4 lower-right
# (r+1, c+1), 8 lower-left (r+1, c).  Edges: 0 top, 1 right, 2 bottom, 3 left.
# For every case, the segments as (from edge, to edge), oriented as scikit-image's 'low': walking
# along a segment, the corners below the level are on the left with columns drawn to the right
# and rows downwards (an image on screen), so curves run counter-clockwise around low islands.  The two
# saddle cases (5 and 10) list the split that keeps the low corners apart, then the split that
# keeps the high corners apart.
_SEGMENTS = {
    0: (), 15: (),
    1: ((0, 3),), 2: ((1, 0),), 4: ((2, 1),), 8: ((3, 2),),
    3: ((1, 3),), 6: ((2, 0),), 12: ((3, 1),), 9: ((0, 2),),
    7: ((2, 3),), 11: ((1, 2),), 13: ((0, 1),), 14: ((3, 0),),
}
_SADDLES = {
    # high corners: upper-left and lower-right; low: upper-right and lower-left
    5: (((0, 3), (2, 1)), ((2, 3), (0, 1))),
    # high corners: upper-right and lower-left
    10: (((1, 0), (3, 2)), ((3, 0), (1, 2))),
}


def _edge_vertices(image: np.ndarray, above: np.ndarray, level: float):
    """The vertex of every sign-changing edge: positions (row, col), and index tables keyed by edge.

    horizontal[r, c] is the vertex on the edge (r, c)-(r, c+1), vertical[r, c] on (r, c)-(r+1, c);
    -1 where the edge does not change sign."""
    points = []
    tables = []
    for axis in (1, 0):  # horizontal edges run along axis 1 (columns), vertical along axis 0
        lo = [slice(None), slice(None)]
        hi = [slice(None), slice(None)]
        lo[axis], hi[axis] = slice(0, -1), slice(1, None)
        v0, v1 = image[tuple(lo)], image[tuple(hi)]
        crossing = above[tuple(lo)] != above[tuple(hi)]
        r, c = np.nonzero(crossing)
        a, b = v0[r, c], v1[r, c]
        t = (level - a) / (b - a)
        # A sample equal to the level sits at t == 0 or 1: move the vertex off the grid point.
        t = np.where((a == level) | (b == level), np.clip(t, EDGE_MARGIN, 1 - EDGE_MARGIN), t)
        position = np.stack([r.astype(np.float64), c.astype(np.float64)], axis=1)
        position[:, axis] += t
        table = np.full(crossing.shape, -1, np.int64)
        table[r, c] = np.arange(len(r)) + sum(len(p) for p in points)
        points.append(position)
        tables.append(table)
    return np.concatenate(points), tables[0], tables[1]


def find_contours(image, level=None, fully_connected="low", positive_orientation="low", *, mask=None):
    """Iso-valued contours of a 2-D array, in scikit-image's `measure.find_contours` conventions.

    Marching squares [1]_: one vertex per grid edge whose ends lie on different
    sides of the level, segments per square from its four corners, chained into
    curves.

    Parameters
    ----------
    image : (R, C) array_like
        The image; NaN samples are masked out.
    level : float, optional
        The iso value; default the middle of the (unmasked) data range.
    fully_connected : {"low", "high"}, default "low"
        Which side of the level is joined across a saddle square's diagonal.
    positive_orientation : {"low", "high"}, default "low"
        With "low" the values below the level lie on the left of every contour
        (counter-clockwise around low islands), with "high" on the right.
    mask : (R, C) bool array, optional
        Keeps only squares whose four corners are True.

    Returns
    -------
    contours : list of (K, 2) float64 arrays
        (row, column) points.  A closed contour repeats its first point at the
        end; an open one runs from border to border (of the image or the mask).
        Open contours come first.

    Raises
    ------
    ValueError
        An image that is not 2-D or has an axis shorter than 2, an unknown
        option, or a mask of another shape or type.

    See Also
    --------
    isoscope.marching_cubes
        The 3-D counterpart: the isosurface of a volume.

    Notes
    -----
    Ties follow the 3-D extractor's rule, not scikit-image's: a sample equal to
    the level counts as above it, and a vertex that would land on it keeps 1/256
    of its edge off it (see the module docstring).  Away from exact ties the
    vertices are scikit-image's.

    References
    ----------
    .. [1] W. E. Lorensen and H. E. Cline, "Marching cubes: a high resolution 3D
       surface construction algorithm", Computer Graphics (SIGGRAPH '87) 21(4),
       163-169, 1987 (its two-dimensional case).

    Examples
    --------
    A circle of radius 0.5 around the image's centre (index 9.5, where 9.5 index
    steps span a distance of 1):

    >>> import numpy as np
    >>> import isoscope
    >>> image = np.hypot(*np.mgrid[-1:1:20j, -1:1:20j])
    >>> contours = isoscope.find_contours(image, 0.5)
    >>> len(contours), contours[0].shape
    (1, (41, 2))
    >>> circle = contours[0]
    >>> bool(np.array_equal(circle[0], circle[-1]))  # closed: the first point again at the end
    True
    >>> bool(np.abs(np.hypot(*(circle - 9.5).T) / 9.5 - 0.5).max() < 0.002)
    True

    The same points as scikit-image's:

    >>> from skimage import measure
    >>> ours, theirs = circle[:-1], measure.find_contours(image, 0.5)[0][:-1]
    >>> bool(np.allclose(ours[np.lexsort(ours.T)], theirs[np.lexsort(theirs.T)]))
    True
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2:
        raise InputError(f"image must be 2-D, got {image.ndim}-D with shape {image.shape}; pick one slice")
    if min(image.shape) < 2:
        raise InputError(f"image shape {image.shape} has an axis shorter than 2; contours need 2x2 samples")
    for name, value in (("fully_connected", fully_connected), ("positive_orientation", positive_orientation)):
        if value not in PARAM_OPTIONS:
            raise InputError(f"{name} must be 'low' or 'high', not {value!r}")
    valid = ~np.isnan(image)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != image.shape or mask.dtype != bool:
            raise InputError(f"mask must be a bool array of the image's shape {image.shape}, "
                             f"got {mask.dtype} {mask.shape}")
        valid &= mask
    if not valid.any():
        return []
    if level is None:
        level = (np.nanmin(image[valid]) + np.nanmax(image[valid])) / 2.0
    level = float(level)

    # Masked-out and NaN samples take the level's value: no edge between two of them crosses, and
    # the vertices of edges touching one are never used (their squares are skipped below).
    filled = np.where(valid, image, level)
    above = filled >= level
    points, horizontal, vertical = _edge_vertices(filled, above, level)

    # Squares whose four corners are valid, and their cases.
    square_valid = valid[:-1, :-1] & valid[:-1, 1:] & valid[1:, 1:] & valid[1:, :-1]
    case = (above[:-1, :-1] * 1 + above[:-1, 1:] * 2 + above[1:, 1:] * 4 + above[1:, :-1] * 8)
    case = np.where(square_valid, case, 0)
    edge_vertex = (horizontal[:-1, :], vertical[:, 1:], horizontal[1:, :], vertical[:, :-1])  # top, right, bottom, left

    starts, ends = [], []
    saddle_choice = 0 if fully_connected == "low" else 1
    for square_case in range(1, 15):
        r, c = np.nonzero(case == square_case)
        if not len(r):
            continue
        segments = _SADDLES[square_case][saddle_choice] if square_case in _SADDLES else _SEGMENTS[square_case]
        for start_edge, end_edge in segments:
            starts.append(edge_vertex[start_edge][r, c])
            ends.append(edge_vertex[end_edge][r, c])
    if not starts:
        return []
    starts, ends = np.concatenate(starts), np.concatenate(ends)
    if positive_orientation == "high":
        starts, ends = ends, starts
    return _walk(points, starts, ends)


def _walk(points: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> list[np.ndarray]:
    """Chain the directed segments start -> end into curves: open ones first, then closed loops."""
    following = np.full(len(points), -1, np.int64)
    following[starts] = ends
    has_incoming = np.zeros(len(points), bool)
    has_incoming[ends] = True
    visited = np.zeros(len(points), bool)
    contours = []
    used = np.zeros(len(points), bool)
    used[starts] = True
    used[ends] = True
    heads = [v for v in np.nonzero(used & ~has_incoming)[0]] + [v for v in np.nonzero(used & has_incoming)[0]]
    for head in heads:
        if visited[head]:
            continue
        chain = [head]
        visited[head] = True
        vertex = following[head]
        while vertex != -1 and not visited[vertex]:
            chain.append(vertex)
            visited[vertex] = True
            vertex = following[vertex]
        if vertex == head:  # back where it started: a closed loop repeats its first point
            chain.append(head)
        contours.append(points[chain])
    return contours
