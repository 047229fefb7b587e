"""Which bricks of a volume over the memory budget to show at full resolution: those in view, nearest the
camera first, within the bytes the budget leaves beside a coarse view of the whole.

Pure logic, no GL and no reading: the volume is cut into bricks of `BRICK_CELLS` cells a side (the chunked
extractor's boxes, big/chunked.py: neighbours share their face's samples, so their meshes meet without a
seam); a coarse view of the whole volume stays resident (every `coarse_step`-th sample, taking at most
`COARSE_SHARE` of the room), and the rest of the room goes to bricks at full resolution.  `plan_refinement`
says, for a camera, which bricks to load and which to let go: the bricks in view, nearest first, until the
next one does not fit (so no brick shown in full is farther than one shown coarse); then bricks already
loaded but no longer wanted (out of view, or farther than the room reaches) stay while room is left, the
nearest first, and the rest go back to coarse: far bricks coarsen only when memory is needed.

Coordinates are the viewer's scene units: sample index times spacing along each axis (model/state.bounds).
The camera is its eye there and a 4x4 clip matrix taking column vectors [x, y, z, 1] to OpenGL clip space
(the viewer's pyrr row-vector matrices: `(view @ projection).T`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .budget import (
    EXTRACTOR_BYTES_PER_SAMPLE,
    MESH_SHARE,
    BudgetError,
    MemoryBudget,
    needed_bytes,
    shown_shape,
    size_text,
)

BRICK_CELLS = 128
"""Cells along each side of a brick (the last along an axis may have fewer)."""
COARSE_SHARE = 0.25
"""The share of the room the coarse view of the whole volume may take; the bricks have the rest."""


@dataclass(frozen=True)
class Brick:
    """Cells `first` to `end` (exclusive) along each axis: samples `first` to `end` inclusive."""
    index: tuple[int, int, int]
    first: tuple[int, int, int]
    end: tuple[int, int, int]

    @property
    def samples(self) -> int:
        """The samples the brick reads (its cells plus one along each axis)."""
        return math.prod(e - f + 1 for f, e in zip(self.first, self.end))

    def box(self, spacing) -> tuple[np.ndarray, np.ndarray]:
        """Its lower and upper corners in scene units."""
        spacing = np.asarray(spacing, dtype=np.float64)
        return np.asarray(self.first) * spacing, np.asarray(self.end) * spacing


@dataclass(frozen=True)
class RefinementPlan:
    """What to do for one camera: `load` (nearest first) and `drop` (back to coarse, farthest first) change
    the set of bricks at full resolution into `wanted` (in view) plus `kept` (loaded before, room left)."""
    wanted: tuple[Brick, ...]
    kept: tuple[Brick, ...]
    load: tuple[Brick, ...]
    drop: tuple[Brick, ...]
    bytes: int   # what the bricks at full resolution take after the change


def bricks_of(shape, cells: int = BRICK_CELLS) -> list[Brick]:
    """The bricks of a volume of `shape` samples, in C order of their index."""
    if cells < 1:
        raise ValueError(f"a brick needs at least one cell a side, got {cells}")
    starts = [range(0, max(int(n) - 1, 1), cells) for n in shape]
    bricks = []
    for index in np.ndindex(*(len(s) for s in starts)):
        first = tuple(s[i] for s, i in zip(starts, index))
        end = tuple(min(f + cells, int(n) - 1) for f, n in zip(first, shape))
        bricks.append(Brick(tuple(int(i) for i in index), first, end))
    return bricks


def _corners(bricks, spacing) -> np.ndarray:
    """(B, 8, 4) homogeneous corners of each brick's box."""
    lower = np.array([b.first for b in bricks], dtype=np.float64) * np.asarray(spacing, dtype=np.float64)
    upper = np.array([b.end for b in bricks], dtype=np.float64) * np.asarray(spacing, dtype=np.float64)
    pick = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, 8).T   # (8, 3) of 0/1
    corners = np.where(pick[None].astype(bool), upper[:, None], lower[:, None])
    return np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2)


def in_view(bricks, spacing, clip_matrix) -> np.ndarray:
    """Whether each brick may be in view: False only where all eight corners of its box lie outside one
    plane of the view frustum (conservative: a box beside a frustum's corner may count as in view)."""
    if not len(bricks):
        return np.zeros(0, dtype=bool)
    clip = _corners(bricks, spacing) @ np.asarray(clip_matrix, dtype=np.float64).T   # (B, 8, 4)
    x, y, z, w = np.moveaxis(clip, 2, 0)
    outside = [x < -w, x > w, y < -w, y > w, z < -w, z > w]
    return ~np.any([side.all(axis=1) for side in outside], axis=0)


def distances(bricks, spacing, eye) -> np.ndarray:
    """The distance from `eye` to the nearest point of each brick's box (0 inside it)."""
    if not len(bricks):
        return np.zeros(0)
    spacing = np.asarray(spacing, dtype=np.float64)
    lower = np.array([b.first for b in bricks], dtype=np.float64) * spacing
    upper = np.array([b.end for b in bricks], dtype=np.float64) * spacing
    eye = np.asarray(eye, dtype=np.float64)
    return np.linalg.norm(eye - np.clip(eye, lower, upper), axis=1)


def brick_bytes(brick: Brick, bytes_per_sample: float) -> int:
    """The bytes `brick`'s samples take at `bytes_per_sample`, rounded up."""
    return int(math.ceil(brick.samples * bytes_per_sample))


def coarse_step(shape, itemsize: int, room: float) -> int:
    """The smallest step whose coarse view of the whole volume takes at most COARSE_SHARE of `room`."""
    step = 1
    while not in_coarse_share(shape, itemsize, room, step) and min(shown_shape(shape, step + 1)) >= 2:
        step += 1
    return step


def in_coarse_share(shape, itemsize: int, room: float, step: int) -> bool:
    """Whether the coarse view of the whole volume at `step` takes at most COARSE_SHARE of `room` (the budget's
    bytes less the meshes' share)."""
    return needed_bytes(shape, itemsize, step) <= room * COARSE_SHARE


def brick_room(shape, itemsize: int, budget: MemoryBudget, cells: int = BRICK_CELLS,
               bytes_per_sample: float | None = None, step: int | None = None,
               min_step: int = 1) -> tuple[int, int]:
    """(the coarse view's step, the bytes left for bricks at full resolution) within `budget`: what the meshes
    take aside (MESH_SHARE), the coarse view of the whole beside (on a software renderer, `budget.software`,
    with llvmpipe's copy of its volume image, in the same RAM as its samples), at `step` where given (a
    pyramid level's factor), else at coarse_step or `min_step` if coarser (a GPU that cannot hold a finer
    view).  BudgetError in one line where the budget is below what one full brick needs beside the coarse
    view."""
    per_sample = itemsize + EXTRACTOR_BYTES_PER_SAMPLE if bytes_per_sample is None else bytes_per_sample
    biggest = max(brick_bytes(b, per_sample) for b in bricks_of(shape, cells))
    coarse, left = _room(shape, itemsize, budget.bytes, budget.software, step, min_step)
    if left < biggest:
        need = biggest / (1 - COARSE_SHARE) / (1 - MESH_SHARE)   # the coarse view then fits in the rest
        while _room(shape, itemsize, need, budget.software, step, min_step)[1] < biggest:   # its image's copy
            need += 1 << 20
        raise BudgetError(f"the memory budget {budget.text} is below what one {cells}^3 brick at full resolution "
                          f"needs beside the coarse view ({size_text(need)} in all); give --memory-budget "
                          f"{math.ceil(need / (1 << 20))}M or more")
    return coarse, left


def _room(shape, itemsize: int, budget_bytes: float, software: bool, step: int | None = None,
          min_step: int = 1) -> tuple[int, int]:
    """brick_room's (step, bytes left) for a budget of `budget_bytes`."""
    room = budget_bytes * (1 - MESH_SHARE)
    step = max(coarse_step(shape, itemsize, room), int(min_step)) if step is None else step
    copy = math.prod(shown_shape(shape, step)) * itemsize if software else 0
    return step, int(room - needed_bytes(shape, itemsize, step) - copy)


def plan_refinement(bricks, refined, eye, clip_matrix, room_bytes: int, bytes_per_sample: float,
                    spacing=(1.0, 1.0, 1.0), cost=None) -> RefinementPlan:
    """Which `bricks` to have at full resolution for this camera (the module's docstring), given the indices
    of those at full resolution now (`refined`) and `room_bytes` for them; a brick takes `cost(brick)` bytes
    where that is given (e.g. a fixed slot), else its samples at `bytes_per_sample`."""
    bricks = list(bricks)

    def size_of(brick: Brick) -> int:
        return cost(brick) if cost is not None else brick_bytes(brick, bytes_per_sample)
    refined = set(refined)
    near = distances(bricks, spacing, eye)
    visible = in_view(bricks, spacing, clip_matrix)
    order = sorted(range(len(bricks)), key=lambda i: (near[i], bricks[i].index))
    wanted, used = [], 0
    for i in order:
        if not visible[i]:
            continue
        size = size_of(bricks[i])
        if used + size > room_bytes:
            break   # nearest first: a farther brick does not take the place of a nearer one
        wanted.append(bricks[i])
        used += size
    chosen = {b.index for b in wanted}
    kept = []
    for i in order:   # loaded before, not wanted now: kept while room is left, the nearest first
        brick = bricks[i]
        if brick.index in refined and brick.index not in chosen:
            size = size_of(brick)
            if used + size <= room_bytes:
                kept.append(brick)
                used += size
    stays = chosen | {b.index for b in kept}
    load = tuple(b for b in wanted if b.index not in refined)
    drop = tuple(bricks[i] for i in reversed(order) if bricks[i].index in refined and bricks[i].index not in stays)
    return RefinementPlan(tuple(wanted), tuple(kept), load, drop, used)


def brick_grid(shape, cells: int = BRICK_CELLS) -> tuple[int, int, int]:
    """How many bricks `bricks_of(shape, cells)` cuts along each axis (its flat indices are C order in it)."""
    return tuple(len(range(0, max(int(n) - 1, 1), cells)) for n in shape)


def face_neighbours(ends, brick: Brick, grid, spacing, cells: int = BRICK_CELLS) -> np.ndarray:
    """For edges whose two ends (`ends`: (E, 2, 3) scene units) lie in one face of `brick`'s box, the flat
    index of the brick across that face; -1 for an edge on the volume's border or on no face."""
    index = np.asarray(ends, dtype=np.float64) / np.asarray(spacing, dtype=np.float64)   # (E, 2, 3) in samples
    other = np.full(len(index), -1, dtype=np.int64)
    for axis in range(3):
        for side, plane in ((-1, brick.first[axis]), (1, brick.end[axis])):
            neighbour = list(brick.index)
            neighbour[axis] += side
            if not 0 <= neighbour[axis] < grid[axis]:
                continue   # the volume's border: no brick across
            on = np.all(np.abs(index[:, :, axis] - plane) < 1e-3, axis=1) & (other < 0)
            other[on] = np.ravel_multi_index(neighbour, grid)
    return other


@dataclass(frozen=True)
class BrickLayout:
    """How a volume over the budget is shown in bricks: every `step`-th sample coarse, bricks of `cells`
    cells a side (a multiple of `step`: a coarse cell lies in one brick), `room` bytes for the meshes of the
    bricks at full resolution, once `work` bytes are kept aside for the brick being extracted."""
    step: int
    cells: int
    room: int
    work: int


def brick_layout(shape, itemsize: int, budget: MemoryBudget, step: int | None = None,
                 min_step: int = 1) -> BrickLayout:
    """The layout of the largest bricks (BRICK_CELLS, then a half and a quarter of it) whose extraction
    takes at most a quarter of what the budget leaves beside the coarse view (so several fit), else the
    smallest that fits at all; BudgetError in one line where none does (brick_room).  `step`: the coarse
    view's, where it is given (a pyramid level's factor); else the smallest whose view takes at most
    COARSE_SHARE of the room, and at least `min_step` (brick_room)."""
    fits = []
    for wanted in (BRICK_CELLS, BRICK_CELLS // 2, BRICK_CELLS // 4):
        try:
            coarse, _ = brick_room(shape, itemsize, budget, wanted, step=step, min_step=min_step)
            cells = coarse * max(1, wanted // coarse)
            coarse, left = brick_room(shape, itemsize, budget, cells, step=coarse)
        except BudgetError as exc:
            error = exc
            continue
        work = max(brick_bytes(b, itemsize + EXTRACTOR_BYTES_PER_SAMPLE) for b in bricks_of(shape, cells))
        fits.append(BrickLayout(coarse, cells, left - work, work))
        if work <= left / 4:
            break
    if not fits:
        raise error
    return fits[-1]
