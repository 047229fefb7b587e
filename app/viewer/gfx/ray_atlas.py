"""The GL side of the rays' bricks (model/ray_bricks.py): one 3-D texture, the atlas, of slots of (cells + 1)^3
samples, each holding a brick at full resolution in the samples' own type, a small one of the same slots'
skipping ranges (RANGE_BRICK cells a side within the brick), and a table texture with a texel per brick of the
volume: its slot's first texel (along the array's axes) and 1 where the brick is in
the atlas, 0 where the rays read the coarse view there (shaders/raycast.frag, BRICKED).

`follow` brings the atlas in line with the model once a frame: a dropped brick's slot is free again, a new
brick's samples are written into a free slot (and let go on the model's side).  The atlas is made for the
model's `slots` and made again when they change.  This class owns its three textures; `release` frees them.
"""
from __future__ import annotations

import math

import numpy as np

from ..model.ray_bricks import RANGE_BRICK, slot_ranges
from ..model.raycast import texture_type, value_map


class RayAtlas:
    """The rays' bricks of one model (model/ray_bricks.py RayBricks) on the GPU."""

    def __init__(self, ctx, model):
        self.ctx, self.model = ctx, model
        self.slot = model.slot_shape[0]
        self.range_cells, self.slot_ranges = RANGE_BRICK, slot_ranges(model.layout.cells)
        self.texture = None
        self.ranges = None           # each slot's own skipping ranges, slot_ranges a side
        self.table = None
        self.kind = texture_type(model.volume.data.dtype)[0]
        self.value_map = value_map(model.volume.data.dtype)
        self.slots: dict[tuple[int, int, int], int] = {}
        self._held: dict[tuple[int, int, int], object] = {}   # the RayBrick each slot holds
        self.grid = (0, 0, 0)
        self.changes = 0             # bumps whenever the bricks in the atlas change
        self._serial = None

    @property
    def shape(self) -> tuple[int, int, int]:
        """The atlas's texels along the array's axes."""
        return tuple(n * self.slot for n in self.grid)

    @property
    def any(self) -> bool:
        """Whether any brick is in the atlas (else the rays read the coarse view alone)."""
        return bool(self.slots)

    def follow(self) -> bool:
        """The atlas in line with the model; whether anything changed (the ray caster's ranges follow)."""
        model = self.model
        if model.serial == self._serial:
            return False
        if model.slots != self.grid or self.table is None:
            self._make(model.slots)
        for index in [i for i in self.slots if self._held.get(i) is not model.loaded.get(i)]:
            del self.slots[index], self._held[index]   # dropped (or dropped and read again since)
        free = sorted(set(range(math.prod(self.grid))) - set(self.slots.values()))
        for index, brick in list(model.loaded.items()):
            if index in self.slots:
                continue
            if brick.samples is None or not free:   # let go before (an atlas made again): read again when wanted
                model.lost(index)
                continue
            slot = free.pop(0)
            origin = np.unravel_index(slot, self.grid)
            # texture x is the array's last axis: the viewport is (x, y, z, width, height, depth)
            corner = tuple(int(o) * self.slot for o in origin)
            self.texture.write(np.ascontiguousarray(brick.samples).tobytes(),
                               viewport=(corner[2], corner[1], corner[0], self.slot, self.slot, self.slot))
            corner, side = tuple(int(o) * self.slot_ranges for o in origin), self.slot_ranges
            self.ranges.write(np.ascontiguousarray(brick.own_ranges, np.float32).tobytes(),
                              viewport=(corner[2], corner[1], corner[0], side, side, side))
            self.slots[index], self._held[index] = slot, brick
            model.uploaded(index)
        self._write_table()
        self._serial = model.serial
        self.changes += 1
        return True

    def _make(self, grid) -> None:
        self._release_textures()
        self.slots.clear()
        self._held.clear()
        self.grid = tuple(grid)
        if math.prod(grid):
            shape = self.shape
            self.texture = self.ctx.texture3d(shape[::-1], 1, dtype=self.kind)
            self.texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)   # the trilinear interpolant, inside a slot
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
            self.ranges = self.ctx.texture3d(tuple(n * self.slot_ranges for n in grid[::-1]), 2, dtype="f4")
            self.ranges.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        grid = self.model.grid
        self.table = self.ctx.texture3d(tuple(grid[::-1]), 4, dtype="f4")
        self.table.filter = (self.ctx.NEAREST, self.ctx.NEAREST)

    def _write_table(self) -> None:
        table = np.zeros(tuple(self.model.grid) + (4,), np.float32)
        for index, slot in self.slots.items():
            origin = np.array(np.unravel_index(slot, self.grid), np.float32) * self.slot
            table[index] = (*origin, 1.0)
        self.table.write(table.tobytes())

    def use(self, atlas_unit: int, table_unit: int, ranges_unit: int) -> None:
        self.texture.use(atlas_unit)
        self.table.use(table_unit)
        self.ranges.use(ranges_unit)

    def _release_textures(self) -> None:
        for texture in (self.texture, self.table, self.ranges):
            if texture is not None:
                texture.release()
        self.texture = self.table = self.ranges = None

    def release(self) -> None:
        """Free the atlas and its table (the model's bricks are read again when wanted)."""
        self._release_textures()
        for index in list(self.slots):
            self.model.lost(index)
        self.slots.clear()
        self._held.clear()
        self._serial = None
        self.grid = (0, 0, 0)
