"""A volume over the memory budget shown in bricks: the coarse view of the whole at once, then the bricks in
view at full resolution, nearest the camera first, within the budget (issue 33, point 3).  The model side,
without GL.

The volume on show is every `layout.step`-th sample of the whole (core/bricks.py brick_layout: the coarse
view takes at most a quarter of the room), or, for an OME-Zarr pyramid, its own level whose factor is a whole
number `layout.step` (read whole; the bricks come from the full level, a brick at a time from the store);
the whole is cut into bricks of `layout.cells` cells a side, a multiple of the step, so each coarse cell lies
in one brick.  Each frame the app hands `look` the camera:
once the selected level rests (its coarse mesh at that value on show, no preview), `plan_refinement` says
which bricks to have at full resolution (in view, nearest first, within `layout.room`; far ones go back to
coarse only when room is needed; where the volume is ray cast too, the rays' bricks take their share of
the room, model/ray_bricks.py), and one brick at a time is asked of a worker: a request with an id,
answered by `take` (model/jobs.py; a headless render, `wait`, makes them all in its frame).  A brick's mesh
is the chunked extractor's box (big/chunked.py extract_box, on the CPU: a worker has no GL context), so
neighbouring bricks at full resolution meet exactly; where a brick meets a coarse one, the GPU side hangs
skirts on both (core/skirts.py, gfx/brick_surface.py).  A new value, side or volume forgets the meshes.

What a brick at full resolution keeps is its mesh (the samples are read a brick at a time on the worker and
let go): the room is spent at an estimate of the mesh's bytes per sample, the coarse mesh's scaled by the
step squared (a surface's triangles grow as the square of the resolution), or what the bricks made so far
took where that is more.  Only plain meshes are refined (marching cubes, Montani's faces, no smoothing or
sharp features, no caps, no label map); other mesh options show the coarse view alone.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.bricks import (
    Brick,
    BrickLayout,
    brick_grid,
    brick_layout,
    bricks_of,
    face_neighbours,
    in_view,
    plan_refinement,
)
from ...core.budget import BudgetError
from ...core.layout import INDEX_BYTES, VERTEX_BYTES
from ...core.skirts import Rim, rim_of
from ...options import MeshOptions
from ...volumes import Volume
from .jobs import Jobs, Response
from .ray_bricks import SURFACES_SHARE, RayBricks

BRICK_JOB = "brick"
MESH_HEADROOM = 1.5
"""The coarse mesh's bytes per sample, scaled to full resolution, times this: what a brick's mesh is planned at."""


@dataclass
class BrickMesh:
    """A brick's mesh at full resolution: `arrays` (verts, faces, normals, values in scene units) until the
    GPU side has them, its open edges on faces shared with other bricks (`rim`, with `across`: the flat
    index of the brick across each edge), and the bytes its mesh takes."""
    brick: Brick
    arrays: tuple | None
    rim: Rim
    across: np.ndarray
    bytes: int


def extract_brick(data, brick: Brick, level: float, spacing, descent: bool, grid, cells: int,
                  progress=None) -> BrickMesh:
    """`brick`'s mesh at full resolution from `data` (an array, memory map or Zarr array: only the brick and
    its one-sample halo are read), on the CPU; a worker's work."""
    from ...big.chunked import extract_box  # here: it brings moderngl (gpu/), which the model never imports
    part = extract_box(data, (brick.first, brick.end), level, spacing, descent, backend="cpu")
    arrays = _no_mesh() if part is None else (part.verts, part.faces, part.normals, part.values)
    rim = rim_of(*arrays)
    across = face_neighbours(rim.ends, brick, grid, spacing, cells)
    inner = across >= 0   # the volume's border needs no skirt
    rim, across = rim.subset(inner), across[inner]
    kept = sum(getattr(rim, name).nbytes for name in ("ends", "normals", "values", "down", "triangle"))
    size = len(arrays[0]) * VERTEX_BYTES + len(arrays[1]) * INDEX_BYTES + kept + across.nbytes   # the rim stays
    return BrickMesh(brick, arrays, rim, across, size)


def _no_mesh():
    """verts, faces, normals, values of a brick the level does not cross."""
    return (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), np.zeros((0, 3), np.float32),
            np.zeros(0, np.float32))


class BrickView:
    """Which bricks of `volume` (the whole, over the budget) are at full resolution, and the one being made."""

    def __init__(self, volume: Volume, layout: BrickLayout, shift=(0.0, 0.0, 0.0)):
        """`shift`: where the coarse view's sample 0 lies in `volume`'s samples (a pyramid level's offset)."""
        self.volume, self.layout = volume, layout
        shape = volume.data.shape
        self.bricks = bricks_of(shape, layout.cells)
        self.grid = brick_grid(shape, layout.cells)
        self.meshes: dict[tuple[int, int, int], BrickMesh] = {}   # at full resolution, for `key`
        self.key: tuple[float, str] | None = None    # (level, gradient direction) the meshes are of
        self.active = False        # the bricks are drawn in place of the selected level's coarse mesh
        self.visible: set[tuple[int, int, int]] = set()   # the bricks in view at the last plan
        self.serial = 0            # bumps on every change of `meshes`: the GPU side follows
        self._rested: tuple | None = None   # the key of the last frame: refinement starts once it holds
        self._asked: tuple[int, tuple] | None = None   # (request id, key) of the brick on the worker
        self.to_load = 0           # bricks the last plan still had to load
        self.jobs = Jobs()
        self.rays = RayBricks(volume, layout, self.bricks, self.grid, self.refines, shift)   # what rays read in full

    @property
    def flat(self) -> dict[tuple[int, int, int], int]:
        """Each brick's flat index (C order in `grid`)."""
        return {b.index: i for i, b in enumerate(self.bricks)}

    @property
    def text(self) -> str:
        """The Stats line: how much is at full resolution."""
        shown = f"{len(self.meshes)} of {len(self.bricks)} bricks at full resolution"
        if self.active and self.visible:
            shown += f" ({len(self.visible & set(self.meshes))} of {len(self.visible)} in view)"
        return shown

    @property
    def full_in_view(self) -> bool:
        """Whether every brick in view is drawn at full resolution."""
        return self.active and bool(self.visible) and self.visible <= set(self.meshes)

    @property
    def settled(self) -> bool:
        """Whether the last plan loads nothing more and no brick is on the worker: what the room holds is in."""
        return self.active and self.to_load == 0 and self.refining is None

    @property
    def refining(self):
        """The brick being made on the worker (its `fraction` and `message`), or None."""
        return self.jobs.current(BRICK_JOB)

    def per_sample(self, coarse_vertices: int, coarse_triangles: int) -> float:
        """The bytes per sample a brick's mesh is planned at (the module's docstring)."""
        coarse = coarse_vertices * VERTEX_BYTES + coarse_triangles * INDEX_BYTES
        estimate = MESH_HEADROOM * coarse * self.layout.step ** 2 / math.prod(self.volume.data.shape)
        made = sum(m.bytes for m in self.meshes.values()) / max(1, sum(m.brick.samples for m in self.meshes.values()))
        return max(estimate, made, 1e-3)

    def look(self, state, eye, clip_matrix, coarse, wait: bool = False) -> None:
        """One frame: plan for the camera at `eye` with `clip_matrix` (scene units to clip space, column
        vectors) and ask for the next brick.  `coarse`: (vertices, triangles) of the selected level's coarse
        mesh when it is on show at rest at the state's value, else None.  `wait` (a headless render): every
        brick the plan loads is made now."""
        self.poll()
        key = (float(state.iso), state.gradient_direction)
        active = coarse is not None and self.refines(state)
        if not active or key != self.key:
            self.forget()
        self.active, self.key = active, key if active else None
        rested, self._rested = self._rested == key, key
        if not active or not (rested or wait):
            return
        spacing = self.volume.spacing
        self.visible = {b.index for b, seen in zip(self.bricks, in_view(self.bricks, spacing, clip_matrix)) if seen}
        room = self.layout.room * (1.0 - SURFACES_SHARE if state.raycast is not None else 1.0)   # the rays' beside
        plan = plan_refinement(self.bricks, self.meshes, eye, clip_matrix, int(room), self.per_sample(*coarse),
                               spacing)
        self.to_load = len(plan.load)
        for brick in plan.drop:   # back to coarse: room was needed nearer
            del self.meshes[brick.index]
            self.serial += 1
        if wait:
            for brick in plan.load:
                self._keep(key, self._extract(brick, key))
        elif plan.load and self.refining is None:
            brick = plan.load[0]
            request = self.jobs.submit(BRICK_JOB, self._extract, brick, key,
                                       message=f"refining brick {brick.index}",
                                       failure=f"brick {brick.index} could not be made")
            self._asked = (request, key)

    @staticmethod
    def refines(state) -> bool:
        """Whether the surfaces of `state` are refined in bricks: plain meshes (marching cubes, Montani's faces,
        no smoothing or sharp features, no caps, no label map), drawn (not the rays alone)."""
        return (state.mesh_options == MeshOptions() and not state.labels and not state.closed
                and (state.raycast is None or state.with_surfaces))

    def _extract(self, brick: Brick, key, progress=None) -> BrickMesh:
        level, direction = key
        return extract_brick(self.volume.data, brick, level, self.volume.spacing, direction == "descent",
                             self.grid, self.layout.cells, progress)

    def poll(self) -> None:
        """Take the brick made on the worker since the last frame, if it is still of the level on show; its
        error is raised (one line)."""
        for response in self.jobs.poll():
            self.take(response)

    def take(self, response: Response) -> None:
        """A worker's answer: kept where it is of the meshes on show, else dropped (its error too: a brick of a
        level no longer asked for says nothing)."""
        if self._asked is None or self._asked[0] != response.request_id:
            return
        asked, self._asked = self._asked, None
        if response.error is not None:
            raise response.error
        self._keep(asked[1], response.value)

    def _keep(self, key, mesh: BrickMesh) -> None:
        if self.active and key == self.key:
            self.meshes[mesh.brick.index] = mesh
            self.serial += 1

    def uploaded(self, index) -> None:
        """The GPU side has brick `index`'s mesh in its buffers: its arrays are let go (its rim stays)."""
        self.meshes[index].arrays = None

    def forget(self) -> None:
        """No brick at full resolution (another value, side or mesh options); the brick on the worker, when it
        comes, is dropped."""
        if self.meshes:
            self.serial += 1
        self.meshes.clear()
        self.visible = set()
        self.to_load = 0
        self._asked = None


def brick_view(full_volume: Volume | None, step: int, budget, shown: Volume | None = None) -> BrickView | None:
    """The bricks of `full_volume` (a volume shown at every `step`-th sample, or from its pyramid level of
    factor `step`: `shown`) where big_volume.downsampled chose their layout's coarse view for it; None where
    the whole is on show, or shown otherwise (a pyramid level whose samples are not `step` full ones along
    every axis, a series)."""
    if full_volume is None or step == 1:
        return None
    if full_volume.pyramid:
        if shown is None or level_factor(full_volume, shown) != step:
            return None   # e.g. a level of (2, 4, 4) full samples: `step`, its first axis' factor, is not its own
        layout = bricks_layout(full_volume, budget, step=step)
    else:
        layout = bricks_layout(full_volume, budget, min_step=step)
    if layout is None or layout.step != step:
        return None
    origin = shown.origin if shown is not None else full_volume.origin   # the coarse view's sample 0, in samples
    return BrickView(full_volume, layout, tuple((o - f) / s for o, f, s in zip(origin, full_volume.origin,
                                                                                full_volume.spacing)))


def bricks_layout(volume: Volume, budget, step: int | None = None, min_step: int = 1) -> BrickLayout | None:
    """The brick layout of `volume` within `budget` (core/bricks.py brick_layout: its coarse view at `step`,
    else at `min_step` or coarser), or None where it is not shown in bricks: a series (each time point read
    at the step), a budget below what one brick needs, a pyramid without `step` (its coarse view is one of its
    levels, read whole: the caller gives that level's whole factor, level_factor)."""
    if volume.time_points > 1 or (volume.pyramid and step is None):
        return None
    try:
        return brick_layout(volume.data.shape, volume.data.dtype.itemsize, budget,
                            step if volume.pyramid else None, min_step=min_step)
    except BudgetError:
        return None


def level_factor(volume: Volume, level) -> int | None:
    """How many of `volume`'s samples one sample of its pyramid `level` (a PyramidLevel, or the Volume shown from
    one: its `spacing` and `data` are read) spans, where that is one whole number
    (2 or more) along all three axes and the level's shape agrees (n samples span the full level's m when
    |n f - m| <= f, as every f-th sample's or f^3 means'); else None: bricks need every coarse cell in one
    brick, and a brick's step one number."""
    ratio = [s / f for s, f in zip(level.spacing, volume.spacing)]
    factor = round(ratio[0])
    if factor < 2 or any(abs(r - factor) > 1e-6 * factor for r in ratio):
        return None
    if any(abs(n * factor - m) > factor for n, m in zip(level.data.shape, volume.data.shape)):
        return None
    return factor
