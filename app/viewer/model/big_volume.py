"""A volume over the memory budget: the viewer shows every `step`-th sample, and exports the full one
in the background.

A volume is shown whole when it and what the viewer makes of it fit the memory budget (core/budget.py: the
GPU's memory, or half the RAM on a software renderer, or --memory-budget); above it the viewer shows every
`step`-th sample along each axis, the smallest step that fits (read a block at a time from a Zarr array
or a memory-mapped file: the whole volume is never in memory), with a note saying so.  While the level
moves, coarse previews keep the frames fluid whatever the budget (gfx/surface.py).  "Export full
resolution..." writes the full volume's mesh on a worker thread with the library's export (big/export.py,
what `isoscope export --chunk` writes), a chunk at a time on the CPU, with progress and a stop; the file is
written atomically (no half file on failure).
"""
from __future__ import annotations

import dataclasses
import os
import threading

import numpy as np

from ...core.bricks import in_coarse_share
from ...core.budget import (
    MAX_STEP,
    MESH_SHARE,
    BudgetError,
    MemoryBudget,
    budget_step,
    needed_bytes,
    shown_shape,
    size_text,
)
from ...core.lazy_arrays import read_block
from ...errors import IsoscopeError
from ...volumes import Volume
from ...volumes.volume import shape_text
from .bricks import bricks_layout, level_factor
from .errors import ViewerError, one_line

EXPORT_CHUNK = 128


def downsampled(volume: Volume, budget: MemoryBudget, refusal=None) -> tuple[Volume, int]:
    """(`volume`, 1) where it fits `budget`, else a volume of fewer samples and how many of the full volume's
    samples one of its steps spans: the finest of the volume's own lower-resolution levels that fits (an
    OME-Zarr pyramid: read whole, never striding through the full level's chunks); where levels of a whole
    factor leave room for a brick at full resolution beside them (bricks.py: the bricks in view then come
    from the full level), the finest of those that takes at most a quarter of the room, as every step-th
    sample's coarse view does, else the finest of them; else every step-th sample, the smallest step that
    fits, or bricks' coarse view (core/budget.py; BudgetError where not even the coarsest view fits).
    `refusal(shape)`: why the extractor here cannot hold a volume of `shape` (a GPU limit), or None; a shape
    it refuses does not fit either (a 1024^3 volume fits llvmpipe's RAM but not its 128 MiB storage blocks)."""
    shape, itemsize = volume.data.shape, volume.data.dtype.itemsize
    step, reason = _fitting_step(shape, itemsize, budget, volume.name, refusal)
    if step == 1:
        return volume, 1
    limited = reason is not None   # by the GPU's limits, not the budget
    whole = (f"{shape_text(shape)}, {size_text(needed_bytes(shape, itemsize) / 0.75)} to show whole")
    fix = "--memory-budget SIZE changes it, 'Export full resolution...' writes the full mesh"
    if reason is not None:
        fix = "'Export full resolution...' writes the full mesh"
    reason = f"this GPU's limits ({reason})" if reason else f"the memory budget of {budget.text}"
    fitting = [level for level in volume.pyramid   # finest first
               if _fitting_step(level.data.shape, level.data.dtype.itemsize, budget, volume.name, refusal)[0] == 1]
    factors = {level.name: level_factor(volume, level) for level in fitting}
    bricked = [level for level in fitting if factors[level.name] is not None   # a brick is made on the CPU: the
               and bricks_layout(volume, budget, factors[level.name]) is not None]   # GPU's limits do not bound it
    room = budget.bytes * (1 - MESH_SHARE)   # as for every step-th sample: the coarse view a quarter of the room
    shared = [level for level in bricked if in_coarse_share(shape, itemsize, room, factors[level.name])]
    for level in (shared or bricked)[:1]:   # bricks: the level, then the bricks in view from the full one
        within = f"{' to fit ' + reason if limited else ''}, the bricks in view refined to full resolution from " \
                 f"the full level within the memory budget of {budget.text}"
        return from_level(volume, level, f"a big volume ({whole}): shown from its level {level.name!r} "
                                         f"({shape_text(level.data.shape)}){within}; {fix}")
    if fitting:
        level = fitting[0]
        return from_level(volume, level, f"a big volume ({whole}): shown from its level {level.name!r} "
                                         f"({shape_text(level.data.shape)}) to fit {reason}{_no_bricks(volume)}; "
                                         f"{fix}")
    if volume.pyramid:   # not even the coarsest level fits: every step-th sample of it
        coarsest = from_level(volume, volume.pyramid[-1])[0]
        level_step = _fitting_step(coarsest.data.shape, coarsest.data.dtype.itemsize, budget, volume.name,
                                   refusal)[0]
        shown = every_step(coarsest, level_step, f"a big volume ({whole}): shown from its coarsest level "
                                                 f"{volume.pyramid[-1].name!r} at one sample in {level_step} to "
                                                 f"fit {reason}; {fix}")
        return shown, max(1, round(shown.spacing[0] / volume.spacing[0]))
    # Bricks: the coarse view, then the bricks in view at full resolution (bricks.py).  Where the GPU's limits,
    # not the budget, refuse the whole, the coarse view is at their step or coarser: a brick is extracted on
    # the CPU, a box at a time, so the limits do not bound it.
    layout = bricks_layout(volume, budget, min_step=step if limited else 1)
    if layout is not None:
        within = f"the memory budget of {budget.text}"
        shown_at = f" to fit {reason}," if limited else ","
        note = (f"a big volume ({whole}): shown at one sample in {layout.step} along each axis{shown_at} the "
                f"bricks in view refined to full resolution within {within}; {fix}")
        return every_step(volume, layout.step, note), layout.step
    note = f"a big volume ({whole}): shown at one sample in {step} along each axis to fit {reason}; {fix}"
    return every_step(volume, step, note), step


def _no_bricks(volume: Volume) -> str:
    """Why a pyramid's level is shown without bricks, where its levels are the reason: none is a whole-number
    downsampling of the full level along every axis."""
    if any(level_factor(volume, level) is not None for level in volume.pyramid):
        return ""
    factors = "x".join(f"{s / f:g}" for s, f in zip(volume.pyramid[0].spacing, volume.spacing))
    return (f" (no bricks at full resolution: they need a level downsampled by one whole number along every axis, "
            f"and level {volume.pyramid[0].name!r} is {factors})")


def _fitting_step(shape, itemsize: int, budget: MemoryBudget, name: str, refusal) -> tuple[int, str | None]:
    """The smallest step that fits `budget` and that `refusal` accepts; and, where `refusal` asked for more
    than the budget, what it said of the shape at the budget's step."""
    step = budget_step(shape, itemsize, budget, name)
    said = refusal(shown_shape(shape, step)) if refusal is not None else None
    if said is None:
        return step, None
    while refusal(shown_shape(shape, step)) is not None:
        step += 1
        if step > MAX_STEP or min(shown_shape(shape, step)) < 2:
            raise BudgetError(f"{name} cannot be shown here even at one sample in {MAX_STEP}: {said}")
    return step, said


def from_level(volume: Volume, level, note: str | None = None) -> tuple[Volume, int]:
    """`volume` shown from its lower-resolution `level` (a PyramidLevel), read whole; and the step, the
    level's spacing over the full one's along the first axis, rounded.  The value range stays the full
    volume's.  The level's sample i is the full level's i x ratio + offset (its spacings' ratio, its offset:
    a pyramid of block means is the blocks' centres): the view's `origin` is that offset in the full volume's
    index x spacing (where its meshes are drawn and exported), and a world transform is composed with it."""
    ratio = [s / f for s, f in zip(level.spacing, volume.spacing)]
    offset = tuple(float(o) for o in getattr(level, "offset", (0.0, 0.0, 0.0)))
    data = read_block(level.data, (slice(None),) * 3)
    world = None
    if volume.world is not None:
        matrix, space = volume.world
        to_full = np.diag([*ratio, 1.0])
        to_full[:3, 3] = offset
        world = (matrix @ to_full, space)
    origin = tuple(o * s + a for o, s, a in zip(offset, volume.spacing, volume.origin))
    notes = [*volume.notes, note] if note else list(volume.notes)
    shown = dataclasses.replace(volume, data=data, spacing=tuple(level.spacing), world=world, notes=notes,
                                _in_memory=None, pyramid=(), origin=origin)
    return shown, max(1, round(ratio[0]))


def view_recipe(volume: Volume, shown: Volume) -> tuple[str | None, int]:
    """How `shown`, `downsampled`'s view of `volume`, was made: (the name of the pyramid level it was read from,
    then one sample in how many of that level's), or (None, 1) where it is `volume` itself or every step-th
    sample of it.  Another time point of the same series is shown the same way (`shown_as`): a series' coarse
    view keeps its samples (a level's means, not the full level's every step-th) and its place (the level's
    offset: Volume.origin) as time moves."""
    if shown is volume:
        return None, 1
    # Coarsest first: a view of level k looks like every 2nd sample of level k - 1 too (its spacing doubled, its
    # sides halved), and a coarser level cannot look like a finer one; so the first match is the level it is.
    for level in reversed(volume.pyramid):
        spacing = tuple(level.spacing)
        steps = max(1, round(shown.spacing[0] / spacing[0]))
        expected = tuple(s * steps for s in spacing) if steps > 1 else spacing   # as every_step computes it
        if tuple(shown.spacing) == expected and tuple(shown.data.shape) == shown_shape(level.data.shape, steps):
            return level.name, steps
    return None, 1


def shown_as(volume: Volume, recipe: tuple[str | None, int], step: int) -> Volume:
    """`volume` (a time point of a series) shown as `view_recipe` says the series' first was: from its pyramid
    level of that name (then one sample in so many of it), or every `step`-th sample of it; a ViewerError line
    where the time point lacks that level."""
    name, level_step = recipe
    if name is None:
        return every_step(volume, step)
    level = next((level for level in volume.pyramid if level.name == name), None)
    if level is None:
        raise ViewerError(f"{volume.name}: this time point has no pyramid level {name!r}, which the series is "
                          "shown from; write every time point with the same levels")
    return every_step(from_level(volume, level)[0], level_step)


def every_step(volume: Volume, step: int, note: str | None = None) -> Volume:
    """A volume of every `step`-th sample of `volume` along each axis (`volume` itself for step 1).  Spacing,
    world transform and value range stay the full volume's (the range bounds the samples kept)."""
    if step == 1:
        return volume
    every = (slice(None, None, step),) * 3
    data = read_block(volume.data, every)   # a memory map's pages are dropped again, as a Zarr array's chunks
    world = None
    if volume.world is not None:
        matrix, space = volume.world
        world = (matrix @ np.diag([step, step, step, 1.0]), space)
    notes = [*volume.notes, note] if note else list(volume.notes)
    return dataclasses.replace(volume, data=data, spacing=tuple(s * step for s in volume.spacing), world=world,
                               notes=notes, _in_memory=None)


class FullResolutionExport:
    """The full volume's mesh at one level written on a worker thread by the library's own export
    (big/export.py: what `isoscope export --chunk` writes); `wait` is the background job's work (model/jobs.py)
    and reports each chunk; `cancel` stops it before its file is written."""

    def __init__(self, volume: Volume, level: float, out, gradient_direction: str, topology: str = "montani"):
        """`volume`: the full volume; `gradient_direction`: the side the viewer shows as inside now; `topology`:
        the ambiguous cells' rule the viewer shows (the Mesh section's)."""
        self.volume, self.level, self.out = volume, float(level), str(out)
        self.gradient_direction, self.topology = gradient_direction, topology
        self.message = f"exporting {os.path.basename(self.out)}"
        self._stop = threading.Event()

    def wait(self, progress) -> str:
        """Write the mesh, reporting to `progress(fraction, message)`; its "wrote" line, or a ViewerError with
        the reason in one line."""
        from ...big.export import write_full_resolution
        try:
            path, vertices, triangles, _ = write_full_resolution(
                self.volume, self.level, self.out, gradient_direction=self.gradient_direction, chunk=EXPORT_CHUNK,
                progress=progress, stop=self._stop, topology=self.topology)
        except (ValueError, OSError, IsoscopeError) as exc:
            raise ViewerError(f"full-resolution export failed: {one_line(exc)}") from None
        return f"wrote {path}: {vertices:,} vertices, {triangles:,} triangles"

    def cancel(self) -> None:
        """Ask the export to stop; `wait` then raises and the file is not written (it is written whole or not at all).
        """
        self._stop.set()
