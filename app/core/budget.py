"""The memory the viewer may give a volume: a budget, not a constant cap.

A volume is shown whole (every sample) when it and what the viewer makes of it fit the budget, and at every
`step`-th sample along each axis otherwise (the smallest step that fits).  What it needs, per sample shown
(measured on the GPU extractor: `Extractor.gpu_bytes()` over the samples, 128^3 to 200^3): the volume image in
the samples' own type (1, 2 or 4 bytes), the extractor's per-word images and brick buffers (0.55-0.72 bytes),
and the coarse previews a drag extracts from (steps 2 to 4: under a fifth more); the meshes take the rest,
MESH_SHARE of the budget.

Where the budget comes from (`default_budget`, with the GPU's own figures where the driver gives them,
gpu/memory.py): the GPU's available memory (GL_NVX_gpu_memory_info, GL_ATI_meminfo) on graphics hardware,
DEFAULT_GPU_BYTES where the driver says nothing, and half the available RAM on a software renderer (llvmpipe
keeps its textures and buffers in RAM).  `--memory-budget SIZE` and `memory_budget=` override it.

On a software renderer the budget is the process's own RAM (`MemoryBudget.software`): what llvmpipe copies
(the coarse view's volume image) is counted, and the process's anonymous RSS grows by at most the budget plus
SOFTWARE_OVERHEAD_BYTES from before a volume is opened.  That is above a fixed part no budget covers: the
process with GL, numba's CPU kernels and a 1280x800 view before any volume, measured at about 165 MiB of
anonymous RSS on llvmpipe (39 MiB after `import isoscope`, 96 MiB with the headless viewer's GL context and
its multisampled 1280x800 targets, 113 MiB with the GPU programs, 163 MiB with numba's CPU kernels, which
the first brick loads: tests/viewer/gfx/test_memory_rss.py loads them first).
"""
from __future__ import annotations

import contextlib
import math
import os
import re
from contextvars import ContextVar
from dataclasses import dataclass

from ..errors import IsoscopeError

EXTRACTOR_BYTES_PER_SAMPLE = 0.75
"""The GPU extractor's work images and buffers per sample, beyond the volume image (measured 0.55-0.72)."""
PREVIEW_SHARE = 1.2
"""The full-resolution extractor and its previews at steps 2, 3 and 4 (1/8 + 1/27 + 1/64 more)."""
MESH_SHARE = 0.25
"""The share of the budget left for the meshes (a few million triangles in a gigabyte)."""
DEFAULT_GPU_BYTES = 2 << 30
"""The budget on graphics hardware whose driver does not say how much memory it has (2 GiB)."""
SOFTWARE_OVERHEAD_BYTES = 16 << 20
"""What a software renderer's process takes beyond the budget while a volume is on show (16 MiB): llvmpipe's
binned triangles, at most renderer.SOFTWARE_DRAW_TRIANGLES at a time (~11 MiB at 1280x800), and the
allocator's slack around the bricks' meshes (measured: benchmarks/results-llvmpipe.md)."""
MIN_BUDGET_BYTES = 1 << 20
"""The smallest budget taken (1 MiB); a volume whose coarsest view needs more is refused by budget_step."""
MAX_STEP = 64
"""The coarsest view the budget may ask for (every 64th sample along each axis)."""

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


class BudgetError(IsoscopeError, ValueError):
    """A memory budget that cannot be taken: not a size, or too small for the volume."""


@dataclass(frozen=True)
class MemoryBudget:
    """`bytes` the viewer may use for the volume on show; `source` says where the figure came from.  `software`:
    the budget is spent on a software renderer, whose images and buffers lie in the process's RAM beside the
    arrays the process keeps (the viewer's GL side sets it): the coarse view's volume image is then counted
    twice, its samples and llvmpipe's copy (core/bricks.py brick_room)."""
    bytes: int
    source: str
    software: bool = False

    @property
    def text(self) -> str:
        """The budget in words: its size and where it came from, e.g. "2.0 GiB (--memory-budget)"."""
        return f"{size_text(self.bytes)} ({self.source})"


def parse_size(text, what: str = "--memory-budget") -> int:
    """A size in bytes from "2G", "512M", "1.5GiB", "300MB", "800000000" (units are powers of 1024, as the GPU
    drivers and the viewer report them); BudgetError in one line for anything else or below MIN_BUDGET_BYTES."""
    if isinstance(text, bool):
        raise BudgetError(f"{what} {text!r} is not a size; give one like 2G or 512M")
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
    else:
        match = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?|\.[0-9]+)\s*([kmgt]?)(?:i?b)?\s*", str(text), re.IGNORECASE)
        if match is None or len(str(text)) > 40:
            shown = str(text)[:40].encode("unicode_escape").decode("ascii")
            raise BudgetError(f"{what} {shown!r} is not a size; give one like 2G, 512M or 1.5GiB")
        value = float(match.group(1)) * _UNITS[match.group(2).lower()]
    if not math.isfinite(value) or value > 1 << 60:
        raise BudgetError(f"{what} {text!r} is more memory than any machine has; give one like 2G or 512M")
    if value < MIN_BUDGET_BYTES:
        raise BudgetError(f"{what} {text!r} is below {size_text(MIN_BUDGET_BYTES)}, too little to show a "
                          "volume; give at least 1M")
    return int(value)


def size_text(n_bytes: float) -> str:
    """`n_bytes` in binary units with one decimal ("1.5 GiB"); plain bytes below 1 KiB."""
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB")
    step = 0
    while n_bytes >= 1024 and step < len(units) - 1:
        n_bytes, step = n_bytes / 1024, step + 1
    return f"{n_bytes:.1f} {units[step]}" if step else f"{int(n_bytes)} B"


def shown_shape(shape, step: int) -> tuple[int, ...]:
    """The samples along each axis of every `step`-th sample of `shape`."""
    return tuple(-(-int(n) // step) for n in shape)


def needed_bytes(shape, itemsize: int, step: int = 1) -> int:
    """What showing every `step`-th sample of a volume of `shape` takes, meshes aside (the module's figures)."""
    samples = math.prod(shown_shape(shape, step))
    return int(samples * (itemsize + EXTRACTOR_BYTES_PER_SAMPLE) * PREVIEW_SHARE)


def budget_step(shape, itemsize: int, budget: MemoryBudget, name: str = "the volume") -> int:
    """The smallest step at which the volume and its meshes fit `budget` (1: the whole volume); BudgetError
    where not even the coarsest view (every MAX_STEP-th sample, two samples an axis at least) fits."""
    room = budget.bytes * (1 - MESH_SHARE)
    step = 1
    while needed_bytes(shape, itemsize, step) > room:
        step += 1
        if step > MAX_STEP or min(shown_shape(shape, step)) < 2:
            coarsest = max(1, step - 1)
            need = needed_bytes(shape, itemsize, coarsest) / (1 - MESH_SHARE)
            raise BudgetError(
                f"the memory budget {budget.text} is below what the coarsest view of {name} "
                f"({'x'.join(map(str, shown_shape(shape, coarsest)))} samples) needs, "
                f"{size_text(need)}; give --memory-budget {math.ceil(need / (1 << 20))}M or more")
    return step


def available_memory_bytes() -> int:
    """What this process may still allocate: MemAvailable on Linux, physical memory elsewhere."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 34


def default_budget(gpu_bytes: int | None, software: bool, driver: str = "") -> MemoryBudget:
    """The budget when none is given: `gpu_bytes` (the GPU's available memory, where its driver says) on
    graphics hardware, else DEFAULT_GPU_BYTES; half the available RAM on a software renderer."""
    if software:
        return MemoryBudget(max(MIN_BUDGET_BYTES, available_memory_bytes() // 2),
                            "half the available memory: a software renderer", software=True)
    if gpu_bytes:
        return MemoryBudget(max(MIN_BUDGET_BYTES, int(gpu_bytes * 0.8)),
                            f"80% of the GPU memory {driver} reports free")
    return MemoryBudget(DEFAULT_GPU_BYTES, "the default: this driver does not report its memory")


def requested_budget(value, what: str = "--memory-budget") -> MemoryBudget | None:
    """A budget the user gave (`--memory-budget SIZE`, `memory_budget=`: bytes or a size text, refused in one
    line as `what`); None where none was given."""
    if value is None:
        return None
    if isinstance(value, MemoryBudget):
        return value
    return MemoryBudget(parse_size(value, what), what)


_GIVEN: ContextVar[MemoryBudget | None] = ContextVar("memory_budget", default=None)


@contextlib.contextmanager
def using_budget(budget: MemoryBudget | None):
    """Within this block, viewers made (the window, `isoscope render` and `movie`, `isoscope.view`, `render`,
    `widget`) take `budget` (None: their GL's default); a command or a Python call sets it once for all the
    viewers it makes."""
    token = _GIVEN.set(budget)
    try:
        yield
    finally:
        _GIVEN.reset(token)


def given_budget() -> MemoryBudget | None:
    """The budget of the enclosing `using_budget` block, or None."""
    return _GIVEN.get()
