"""The value ranges that let a ray skip empty space (viewer/gfx/raycast.py, shaders/raycast.frag): each brick's
(min, max) over its samples, bricks of RANGE_BRICK cells a side of the volume on show, and macro bricks of
MACRO of those a side.  Pure numpy.

A volume over the memory budget is ray cast from its coarse view where its bricks at full resolution are not
loaded (viewer/model/ray_bricks.py): the ranges of the coarse view's bricks are then widened by what the full
resolution holds inside them (`ranges_within`, `widened`), so a brick is skipped only where no sample the rays
may read there, coarse or full, could change the picture.
"""
from __future__ import annotations

import numpy as np

RANGE_BRICK = 8   # samples a side of the bricks whose (min, max) let rays skip empty space
MACRO = 4         # bricks a side of the macro bricks a ray looks at first (empty space left in bigger steps)


def brick_ranges(data: np.ndarray, brick: int) -> np.ndarray:
    """(bx, by, bz, 2) float32: the (min, max) of the samples of each brick of `brick` cells a side (samples
    b*brick .. (b+1)*brick along each axis, the faces shared with the next brick included), so a ray can
    tell from one fetch that the trilinear interpolant inside a brick stays within that range.  An axis at a
    time: each cell's range along it (a sample and the next), then those of `brick` cells together."""
    return ranges_within(data, (0, 0, 0), brick)[1]


def coarser_ranges(ranges: np.ndarray, by: int) -> np.ndarray:
    """The (min, max) of `by` x `by` x `by` bricks of `ranges` (brick_ranges'; the last ones along an axis fewer):
    the range of the samples of all of them, so a brick of these is skippable wherever all of its are."""
    low, high = ranges[..., 0], ranges[..., 1]
    for axis in range(3):
        starts = np.arange(0, low.shape[axis], by)
        low = np.minimum.reduceat(low, starts, axis=axis)
        high = np.maximum.reduceat(high, starts, axis=axis)
    return np.stack([low, high], axis=-1).astype(np.float32)


def ranges_within(samples: np.ndarray, first, size: int, shift=(0.0, 0.0, 0.0)) -> tuple[tuple[int, int, int],
                                                                                          np.ndarray]:
    """The (min, max) of `samples` (a part of a larger volume whose first sample is `first` along each axis)
    in each brick of `size` cells a side of that volume (cells b*size .. (b+1)*size, global indices) the part
    reaches: (the first such brick's index, (n0, n1, n2, 2) float32).  As `brick_ranges`, a cell counts in the
    brick it starts in, with both of its samples.  `shift` (samples, along each axis): the bricks start there
    instead (brick b spans b*size + shift .. (b+1)*size + shift: a coarse view's bricks where its samples lie
    off this volume's grid, Volume.origin); a cell then counts in every brick it overlaps, so a brick's range
    holds every sample whose interpolant reaches into it.  A first index may be negative (a cell before the
    first shifted brick): `widened` counts it in brick 0."""
    low = high = np.asarray(samples)
    origin = []
    for axis in range(3):
        if low.shape[axis] > 1:
            first_half, second_half = [slice(None)] * 3, [slice(None)] * 3
            first_half[axis], second_half[axis] = slice(0, -1), slice(1, None)
            low = np.minimum(low[tuple(first_half)], low[tuple(second_half)])
            high = np.maximum(high[tuple(first_half)], high[tuple(second_half)])
        cells = int(first[axis]) + np.arange(low.shape[axis])
        moved = float(shift[axis])
        if moved == 0.0:
            which = cells // size   # each cell's brick
            starts = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
            low = np.minimum.reduceat(low, starts, axis=axis)
            high = np.maximum.reduceat(high, starts, axis=axis)
            origin.append(int(which[0]))
            continue
        # cell [c, c + 1] overlaps bricks floor((c - shift) / size) .. ceil((c + 1 - shift) / size) - 1; a
        # hair wider, so a shift that is not exact in binary never leaves a cell out of a brick it touches
        lowest = np.floor((cells - moved) / size - 1e-9).astype(np.int64)
        highest = (np.ceil((cells + 1 - moved) / size + 1e-9) - 1).astype(np.int64)
        bricks = range(int(lowest.min()), int(highest.max()) + 1)
        low = np.stack([np.take(low, np.flatnonzero((lowest <= b) & (b <= highest)), axis=axis).min(axis=axis)
                        for b in bricks], axis=axis)
        high = np.stack([np.take(high, np.flatnonzero((lowest <= b) & (b <= highest)), axis=axis).max(axis=axis)
                         for b in bricks], axis=axis)
        origin.append(bricks.start)
    return tuple(origin), np.stack([low, high], axis=-1).astype(np.float32)


def widened(ranges: np.ndarray, parts) -> np.ndarray:
    """`ranges` (brick_ranges') with each of `parts` ((first brick, ranges) of `ranges_within`) taken in: a brick's
    (min, max) over both.  A part's bricks past the last along an axis count in the last (the shader's lookup
    clamps there too: the full volume may reach a little past its coarse view's last sample), and those before
    the first (a first index below 0: a shifted part's cells before the coarse view's first sample) in the first."""
    out = ranges.copy()
    counts = out.shape[:3]
    for origin, part in parts:
        index = np.ix_(*(np.clip(o + np.arange(n), 0, c - 1) for o, n, c in zip(origin, part.shape[:3], counts)))
        np.minimum.at(out[..., 0], index, part[..., 0])
        np.maximum.at(out[..., 1], index, part[..., 1])
    return out
