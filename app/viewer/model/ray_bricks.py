"""A volume over the memory budget ray cast brick by brick (issue 37): the rays read the samples at full
resolution inside the bricks in view that are loaded, and the coarse view elsewhere.  The model side, without GL.

The bricks are those of the surfaces (model/bricks.py BrickView: `cells` cells a side, neighbours sharing their
face's samples).  Each frame the app hands `look` the camera: `plan_refinement` picks the bricks in view,
nearest the camera first, as many as the room holds, and one brick at a time is read on a worker (a request
with an id, answered by `take`; a headless render, `wait`, reads them all in its frame).  A brick's samples
are kept as the ray caster's texture takes them (texture_samples: their own type where GL keeps it exactly),
padded to a slot of (cells + 1)^3 samples, with the (min, max) of the full resolution inside each of the coarse
view's skipping bricks (core/value_ranges.py ranges_within), until the GPU side has them in its atlas
(gfx/ray_atlas.py): then the samples are let go (`uploaded`).

The room: every slot takes its bytes; the rays have the bricks' room (core/bricks.py BrickLayout.room) alone,
or SURFACES_SHARE of it where the surfaces are refined with them (the surfaces' bricks the rest), less the ray
caster's own texture of the coarse view and READS_IN_FLIGHT slots for the brick being read.  The rays'
bricks are forgotten when the volume is no longer ray cast, and when the room changes (the GPU side's
atlas is made for a number of slots).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.bricks import Brick, BrickLayout, in_view, plan_refinement
from ...core.budget import shown_shape
from ...core.value_ranges import RANGE_BRICK, ranges_within
from .errors import READ_ERRORS
from .jobs import Jobs, Response
from .raycast import texel_bytes, texture_samples

RAY_BRICK_JOB = "ray brick"
ATLAS_SIDE = 2048
"""Texels along each axis of the atlas at most: every OpenGL 4.x GPU's GL_MAX_3D_TEXTURE_SIZE is at least this."""
SURFACES_SHARE = 0.5
"""The share of the bricks' room the rays' bricks take where the surfaces are drawn with them (and refined too)."""
READS_IN_FLIGHT = 2
"""Slots of the room kept for the brick being read (the part read and its copy padded to a slot)."""


@dataclass
class RayBrick:
    """A brick's samples at full resolution, padded to a slot, and the (min, max) of its own skipping bricks
    (RANGE_BRICK cells a side from its first sample, padded to slot_ranges a side): None once the GPU side has
    them; and the (min, max) of its samples in each of the coarse view's skipping bricks it reaches: (first such
    brick, ranges)."""
    brick: Brick
    samples: np.ndarray | None
    own_ranges: np.ndarray | None
    ranges: tuple


def slot_ranges(cells: int) -> int:
    """A slot's skipping bricks along each axis (RANGE_BRICK cells a side, the last fewer)."""
    return -(-cells // RANGE_BRICK)


def read_ray_brick(data, brick: Brick, cells: int, range_cells: int, progress=None,
                   shift=(0.0, 0.0, 0.0)) -> RayBrick:
    """`brick`'s samples from `data` (an array, memory map or Zarr array: only the brick is read), as the ray
    caster's texture takes them, padded to (cells + 1)^3 by repeating its last samples (a slot's
    unused texels are never read between two samples, but they are never garbage either); a worker's work.
    `range_cells`: the full samples a side of the coarse view's skipping bricks; `shift`: where they start, in full
    samples (the coarse view's sample 0: a pyramid level's offset): the brick's samples count in each of them
    its cells reach into, so a ray skipping one of them skips no sample of the brick it should read."""
    part = np.asarray(data[tuple(slice(f, e + 1) for f, e in zip(brick.first, brick.end))])
    samples = texture_samples(part)
    ranges = ranges_within(samples, brick.first, range_cells, shift)
    _, own = ranges_within(samples, (0, 0, 0), RANGE_BRICK)
    return RayBrick(brick, _padded(samples, (cells + 1,) * 3), _padded(own, (slot_ranges(cells),) * 3 + (2,)), ranges)


def _padded(array: np.ndarray, shape) -> np.ndarray:
    """`array` grown to `shape` by repeating its last entries."""
    pad = [(0, n - m) for n, m in zip(shape, array.shape)]
    return np.pad(array, pad, mode="edge") if any(after for _, after in pad) else array


def slot_grid(slots: int, per_axis: int) -> tuple[int, int, int]:
    """Slots along each of the atlas's array axes: the most there can be, at most `slots` in all (the room's)
    and `per_axis` along each axis."""
    best = (0, 0, 0)
    for fast in range(1, min(per_axis, slots) + 1):
        for middle in range(1, min(per_axis, slots // fast) + 1):
            grid = (min(per_axis, slots // (fast * middle)), middle, fast)
            if math.prod(grid) > math.prod(best):
                best = grid
    return best


class RayBricks:
    """Which bricks of a volume shown in bricks (a BrickView's `volume`, `bricks`, `grid` and `layout`) the
    rays read at full resolution, and the one being read."""

    def __init__(self, volume, layout: BrickLayout, bricks, grid, surfaces_refine=lambda state: False,
                 shift=(0.0, 0.0, 0.0)):
        self.volume, self.layout, self.bricks, self.grid = volume, layout, bricks, grid
        self.shift = tuple(float(s) for s in shift)   # the coarse view's sample 0, in full samples (its origin)
        self.surfaces_refine = surfaces_refine   # whether the surfaces' bricks take a share of the room (state)
        self.failed: set[tuple[int, int, int]] = set()   # bricks that could not be read: not asked again
        self.loaded: dict[tuple[int, int, int], RayBrick] = {}
        self.slots = (0, 0, 0)     # the atlas's slots along each array axis (slot_grid; none: not ray cast)
        self.visible: set[tuple[int, int, int]] = set()
        self.to_load = 0
        self.serial = 0            # bumps on every change of `loaded` or `slots`: the GPU side follows
        self._asked: tuple[int, tuple] | None = None   # (request id, brick index) on the worker
        self.jobs = Jobs()

    @property
    def slot_shape(self) -> tuple[int, int, int]:
        return (self.layout.cells + 1,) * 3

    @property
    def texel_bytes(self) -> int:
        """What one sample takes in the ray caster's textures (texture_type)."""
        return texel_bytes(self.volume.data.dtype)

    @property
    def slot_bytes(self) -> int:
        """What one slot of the atlas takes: (cells + 1)^3 samples in the texture's type."""
        return math.prod(self.slot_shape) * self.texel_bytes

    @property
    def range_cells(self) -> int:
        """Full samples a side of the coarse view's skipping bricks (RANGE_BRICK of its samples)."""
        return RANGE_BRICK * self.layout.step

    @property
    def text(self) -> str:
        """The Stats line: how many bricks the rays read at full resolution."""
        shown = f"{len(self.loaded)} of {len(self.bricks)} bricks at full resolution"
        if self.visible:
            shown += f" ({len(self.visible & set(self.loaded))} of {len(self.visible)} in view)"
        return shown

    @property
    def reading(self):
        """The brick being read on the worker (its `fraction` and `message`), or None."""
        return self.jobs.current(RAY_BRICK_JOB)

    @property
    def capacity(self) -> int:
        """How many bricks the atlas holds."""
        return math.prod(self.slots)

    def atlas_slots(self, state) -> tuple[int, int, int]:
        """The atlas's slots for the rays in `state` (slot_grid: as many as the room holds, no more than the
        bricks; none where the volume is not ray cast)."""
        if state.raycast is None:
            return (0, 0, 0)
        room = self.layout.room * (SURFACES_SHARE if self.surfaces_refine(state) else 1.0)
        room -= READS_IN_FLIGHT * self.slot_bytes   # a brick being read: its part and its padded copy
        # and the ray caster's own texture of the coarse view (gfx/raycast.py), beside the extractor's
        room -= math.prod(shown_shape(self.volume.data.shape, self.layout.step)) * self.texel_bytes
        return slot_grid(int(min(len(self.bricks), max(room, 0) // self.slot_bytes)), ATLAS_SIDE // self.slot_shape[0])

    def look(self, state, eye, clip_matrix, wait: bool = False, each=None) -> None:
        """One frame: plan for the camera at `eye` with `clip_matrix` (scene units to clip space, column vectors)
        and ask for the next brick; `wait` (a headless render): every brick the plan loads is read now, `each()`
        called after each (the GPU side takes it then: no more than one brick's samples are held at a time)."""
        self.poll()
        slots = self.atlas_slots(state)
        if slots != self.slots:
            self.forget()
            self.slots = slots
            self.serial += 1
        capacity = self.capacity
        if not capacity:
            return
        spacing = self.volume.spacing
        self.visible = {b.index for b, seen in zip(self.bricks, in_view(self.bricks, spacing, clip_matrix)) if seen}
        slot = self.slot_bytes
        readable = [b for b in self.bricks if b.index not in self.failed]
        plan = plan_refinement(readable, self.loaded, eye, clip_matrix, capacity * slot, 0.0, spacing,
                               cost=lambda _: slot)
        self.to_load = len(plan.load)
        for brick in plan.drop:
            del self.loaded[brick.index]
            self.serial += 1
        if wait:
            error = None
            for brick in plan.load:
                try:
                    self._keep(self._read(brick))
                except READ_ERRORS as exc:   # the others are read all the same; the first error is said
                    self.failed.add(brick.index)
                    error = error or exc
                    continue
                if each is not None:
                    each()
            self.to_load = 0
            if error is not None:
                raise error
        elif plan.load and self.reading is None:
            brick = plan.load[0]
            request = self.jobs.submit(RAY_BRICK_JOB, self._read, brick,
                                       message=f"reading brick {brick.index} for the rays",
                                       failure=f"brick {brick.index} could not be read")
            self._asked = (request, brick.index)

    def _read(self, brick: Brick, progress=None) -> RayBrick:
        return read_ray_brick(self.volume.data, brick, self.layout.cells, self.range_cells, progress, self.shift)

    def poll(self) -> None:
        """Take the brick read on the worker since the last frame; its error is raised (one line)."""
        for response in self.jobs.poll():
            self.take(response)

    def take(self, response: Response) -> None:
        """A worker's answer: kept where it is the brick last asked for and there is room, else dropped."""
        if self._asked is None or self._asked[0] != response.request_id:
            return
        asked, self._asked = self._asked, None
        if response.error is not None:
            self.failed.add(asked[1])   # said once, not asked again every frame
            raise response.error
        self._keep(response.value)

    def _keep(self, brick: RayBrick) -> None:
        if len(self.loaded) < self.capacity:
            self.loaded[brick.brick.index] = brick
            self.serial += 1

    def uploaded(self, index) -> None:
        """The GPU side has brick `index`'s samples in its atlas: they are let go here (its ranges stay)."""
        self.loaded[index].samples = self.loaded[index].own_ranges = None

    def lost(self, index) -> None:
        """The GPU side no longer has brick `index` (its atlas made again): it is read again when wanted."""
        if self.loaded.pop(index, None) is not None:
            self.serial += 1

    def forget(self) -> None:
        """No brick at full resolution for the rays; the brick on the worker, when it comes, is dropped; bricks
        that could not be read are asked for again (the rays back on, another room)."""
        if self.loaded:
            self.serial += 1
        self.loaded.clear()
        self.failed.clear()
        self.visible = set()
        self.to_load = 0
        self._asked = None
