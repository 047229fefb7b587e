"""scikit-image's `values` for a marching-cubes mesh: per vertex, the spread of the cells next to it.

``skimage.measure.marching_cubes`` documents `values` as "the maximum value of the data in the local
region near each vertex"; what its Lewiner traversal stores (`Cell.prepare_for_adding_triangles` and
`Cell.add_face` in ``_marching_cubes_lewiner_cy.pyx``) is, for each cell that gives a triangle using
the vertex, the spread of the cell's eight samples with the level subtracted, each range taken with 0
(``max(0, v - level) - min(0, v - level)`` over the corners, in float64 of the float32 samples), and
per vertex the largest such spread, as float32.  A cell with triangles has samples on both sides of the
level, so its spread is just max - min.

Every cell around a grid edge that the level crosses has that crossing among its triangles' corners (in
either table), so a vertex's value is the largest spread over the cells next to its edge: four inside
the volume, fewer on its border, and with a mask only the cells it keeps (those whose far corner it
holds, as `isoscope.core.masking`).  This module finds those cells from the vertex's position: along
each axis where the vertex sits on a grid plane (its coordinate within `ON_PLANE` of a whole number of
cells) the cells on both sides, elsewhere the one it lies in.  For a vertex on a grid edge that is
scikit-image's set; a sharp-feature vertex (`isoscope.core.sharp`) inside a cell takes that cell's
spread, one on a cell's face or edge the largest of the cells there.

Positions are read in cells: a vertex's coordinate along its edge keeps 1/256 of a cell off the grid
points (`isoscope.cpu.cubes`), well beyond `ON_PLANE`, while float32 positions stay within it of the
planes up to 16384 cells along an axis.
"""
from __future__ import annotations

import numpy as np
from numba import prange

from .jit import _cached_njit, _launch_guard
from .samples import sample, sample_view

__all__ = ["skimage_orientation", "skimage_values"]

ON_PLANE = 1.0 / 512  # cells: a coordinate this close to a whole number lies on that grid plane
SLAB_CELLS = 64  # cells along axis 0 read at a time from an array that is not in memory (zarr, dask)


@_cached_njit(inline="always", error_model="numpy")
def _cell_span(c, n_cells):
    """The first and last cell along one axis that a vertex at grid coordinate `c` touches."""
    r = np.floor(c + 0.5)
    if abs(c - r) < ON_PLANE:
        lo, hi = np.int64(r) - 1, np.int64(r)
    else:
        lo = hi = np.int64(np.floor(c))
    return max(lo, 0), min(hi, n_cells - 1)


@_cached_njit(parallel=True, error_model="numpy")
def _spreads(flat, swap, layout, row0, n_cells, verts, spacing, level, mask, use_mask, step, out):
    """out[n]: the largest spread over the cells vertex n touches (those the mask keeps); the samples
    (`isoscope.cpu.samples`: flat, swap, layout) hold the layout's samples from row `row0` of axis 0 on,
    `verts / spacing` are the vertices' positions in cells."""
    for n in prange(verts.shape[0]):
        grid = (layout[0], layout[1], layout[2], layout[3], layout[4], layout[5], layout[6])  # a tuple in the
        # loop's body (numba's parallel loops capture no tuples): its numbers stay in registers
        lo0, hi0 = _cell_span(np.float64(verts[n, 0]) / spacing[0], n_cells[0])
        lo1, hi1 = _cell_span(np.float64(verts[n, 1]) / spacing[1], n_cells[1])
        lo2, hi2 = _cell_span(np.float64(verts[n, 2]) / spacing[2], n_cells[2])
        best = 0.0
        for i in range(lo0, hi0 + 1):
            for j in range(lo1, hi1 + 1):
                for k in range(lo2, hi2 + 1):
                    if use_mask and not mask[(i + 1) * step, (j + 1) * step, (k + 1) * step]:
                        continue
                    high = 0.0
                    low = 0.0
                    for c in range(8):
                        v = np.float64(sample(flat, swap, grid, i - row0 + (c & 1), j + (c >> 1 & 1), k + (c >> 2)))
                        v -= level
                        high = max(high, v)
                        low = min(low, v)
                    best = max(best, high - low)
        out[n] = np.float32(best)


@_cached_njit(parallel=True)
def _reverse_rows(faces):
    for n in prange(faces.shape[0]):
        first = faces[n, 0]
        faces[n, 0] = faces[n, 2]
        faces[n, 2] = first


def skimage_orientation(faces: np.ndarray, normals: np.ndarray, descent: bool):
    """isoscope's outward mesh turned to scikit-image's orientation: each triangle's corners in reverse
    order, and the normals down the gradient (negated for "ascent").  In place where the arrays are
    writable and C-contiguous (a call's own: a copy of the faces took 15-50 ms of a 3.8 M-triangle
    gyroid's one-shot call; this takes a few), else as new arrays."""
    if faces.flags.c_contiguous and faces.flags.writeable and faces.dtype == np.int32 and faces.ndim == 2:
        if len(faces):
            with _launch_guard():
                _reverse_rows(faces)
    else:
        faces = np.ascontiguousarray(faces[:, ::-1])
    if not descent:
        normals = np.negative(normals, out=normals) if normals.flags.writeable else -normals
    return faces, normals


def skimage_values(field, verts, level, spacing, mask=None, step=1) -> np.ndarray:
    """scikit-image's `values` for the vertices `verts` of a marching-cubes mesh of `field` at `level`.

    `field`: the grid the mesh was extracted from (every `step`-th sample of the volume: numpy, a
    memory map, or a zarr/dask array, read SLAB_CELLS planes at a time); `spacing`: that grid's
    (the volume's times `step`); `mask`: the volume's boolean mask (cell (i, j, k) of the grid is kept
    where it holds its far corner, ((i, j, k) + 1) * step).  Returns (N,) float32."""
    verts = np.ascontiguousarray(verts, np.float32)
    out = np.zeros(len(verts), np.float32)
    if not len(verts):
        return out
    spacing = np.asarray(spacing, np.float64)
    n_cells = np.asarray(field.shape, np.int64) - 1
    use_mask = mask is not None
    mask = np.ones((1, 1, 1), np.bool_) if mask is None else np.ascontiguousarray(mask, np.bool_)
    level = float(level)
    if isinstance(field, np.ndarray):
        view = sample_view(field)   # read in place: any memory order, byte order, 8- to 64-bit type
        with _launch_guard():
            _spreads(view.flat, view.swap, view.grid, 0, n_cells, verts, spacing, level, mask, use_mask, int(step),
                     out)
        return out
    # Slabs of SLAB_CELLS cells along axis 0: a vertex belongs to the slab of the cell its coordinate
    # rounds into, and touches at most the cell before it, so each slab reads one plane more each side.
    home = np.clip(np.floor(verts[:, 0] / spacing[0]).astype(np.int64), 0, n_cells[0] - 1) // SLAB_CELLS
    order = np.argsort(home, kind="stable")
    bounds = np.searchsorted(home[order], np.arange(home[order[-1]] + 2))
    for slab in np.flatnonzero(np.diff(bounds)):
        which = order[bounds[slab]:bounds[slab + 1]]
        row0 = max(slab * SLAB_CELLS - 1, 0)
        block = sample_view(np.asarray(field[row0:min((slab + 1) * SLAB_CELLS + 2, field.shape[0])]))
        part = np.zeros(len(which), np.float32)
        with _launch_guard():
            _spreads(block.flat, block.swap, block.grid, row0, n_cells, verts[which], spacing, level, mask, use_mask,
                     int(step), part)
        out[which] = part
    return out
