"""A volume over the memory budget: the viewer shows every `step`-th sample, and exports the full one
in the background.

A volume is shown whole when it and what the viewer makes of it fit the memory budget (core/budget.py: the
GPU's memory, or half the RAM on a software renderer, or --memory-budget); above it the viewer shows every
`step`-th sample along each axis, the smallest step that fits (read a block at a time from a Zarr array
or a memory-mapped file: the whole volume is never in memory), with a note saying so.  While the level
moves, coarse previews keep the frames fluid whatever the budget (gfx/surface.py).  "Export full
resolution..." then runs `isoscope export --chunk` in a child process, which extracts the full volume a
chunk at a time (chunked.py) with its own GL context; the window only reads the child's progress lines, so
it stays responsive, and the file is written atomically by the child (no half file on failure).
"""
from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np

from ...core.budget import MemoryBudget, budget_step, needed_bytes, size_text
from ...core.lazy_arrays import read_block
from ...volumes import Volume
from .errors import ViewerError

EXPORT_CHUNK = 128


def downsampled(volume: Volume, budget: MemoryBudget) -> tuple[Volume, int]:
    """(`volume`, 1) where it fits `budget`, else a volume of every step-th sample of it and that step, the
    smallest step that fits (core/budget.py; BudgetError where not even the coarsest view fits)."""
    shape, itemsize = volume.data.shape, volume.data.dtype.itemsize
    step = budget_step(shape, itemsize, budget, volume.name)
    if step == 1:
        return volume, 1
    note = (f"a big volume ({'x'.join(map(str, shape))}, {size_text(needed_bytes(shape, itemsize) / 0.75)} to "
            f"show whole): shown at one sample in {step} along each axis to fit the memory budget of "
            f"{budget.text}; --memory-budget SIZE changes it, 'Export full resolution...' writes the full mesh")
    return every_step(volume, step, note), step


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
    """`isoscope export SOURCE --iso LEVEL --out PATH --chunk N` in a child process, started at once;
    `wait` (a background job's work, model/jobs.py) reads its progress from its stderr."""

    def __init__(self, volume: Volume, level: float, out, gradient_direction: str):
        """`volume`: the full volume (its source is re-opened by the child, with its open options);
        `gradient_direction`: the side the viewer shows as inside now."""
        self.out = str(out)
        self.message = f"exporting {os.path.basename(self.out)}"
        inside = "below" if gradient_direction == "ascent" else "above"   # the command line's word for it
        reopen = []   # the flags it was opened with: --dims X Y Z, --frame N, ...
        for name, value in volume.open_options.items():
            reopen += [f"--{name}", *map(str, value if isinstance(value, (list, tuple)) else [value])]
        command = [sys.executable, "-m", "isoscope", "export", volume.source, "--iso", repr(float(level)),
                   "--out", self.out, "--chunk", str(EXPORT_CHUNK), "--inside", inside, *reopen]
        env = dict(os.environ, ISOSCOPE_PROGRESS="1")   # progress lines even though stderr is a pipe
        self._process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                         stderr=subprocess.PIPE, text=True, env=env)

    def wait(self, progress) -> str:
        """Report the child's progress lines to `progress(fraction, message)` until it ends; its
        "wrote" line, or a ViewerError with its last line."""
        last = ""
        for line in self._process.stderr:
            line = line.strip()
            if not line:
                continue
            last = line
            words = line.rsplit(" ", 1)
            if len(words) == 2 and words[1].endswith("%"):
                try:
                    progress(float(words[1][:-1]) / 100, words[0])
                except ValueError:
                    pass
        code = self._process.wait()
        if code != 0:
            raise ViewerError(last or f"the export stopped (exit code {code})")
        return f"wrote {self.out}"

    def cancel(self) -> None:
        if self._process.poll() is None:
            self._process.terminate()
